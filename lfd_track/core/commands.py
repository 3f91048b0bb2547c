"""The paper's three discrete drive commands (the env's action space)."""

from __future__ import annotations

from enum import IntEnum


class Command(IntEnum):
    """Discrete drive command; the integer is the Gymnasium action and the MLP output index."""

    FORWARD = 0
    LEFT = 1  # pivot in place, counter-clockwise (left tread back, right tread forward)
    RIGHT = 2  # pivot in place, clockwise

    @property
    def letter(self) -> str:
        """One-letter code used on the wire and in logs (F, L, R)."""
        return "FLR"[int(self)]
