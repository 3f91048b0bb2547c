"""The window of ``render_mode="human"`` and the keys of ``gymnasium.utils.play.play``.

Both need pygame, installed by the ``play`` extra (``pip install 'lfd-track[play]'``); without it
they raise :class:`~lfd_track.utils.extras.MissingExtraError`, whose one line names that command.
The window shows the same top-down picture as ``render_mode="rgb_array"`` (track, rover, camera
footprint, trajectory), one picture per ``reset`` and ``step``, at most ``render_fps`` a second.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from ..utils.extras import needs_extra

ACTION_KEYS: dict[str, tuple[str, ...]] = {
    "forward": ("K_UP", "K_w"),
    "left": ("K_LEFT", "K_a"),
    "right": ("K_RIGHT", "K_d"),
}
"""Command -> the pygame key names that give it: arrow keys or W, A, D."""
COMMANDS = {"forward": 0, "left": 1, "right": 2}


def load_pygame() -> Any:
    """The pygame module (its greeting on import silenced); MissingExtraError without it."""
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    with needs_extra("play"):
        import pygame
    return pygame


def keys_to_action() -> dict[tuple[int, ...], int]:
    """The key map of :func:`gymnasium.utils.play.play`: one pressed key -> an action."""
    pygame = load_pygame()
    return {
        (getattr(pygame, key),): COMMANDS[command]
        for command, keys in ACTION_KEYS.items()
        for key in keys
    }


class TopDownWindow:
    """A pygame window showing RGB pictures, paced to ``fps`` pictures a second."""

    def __init__(self, fps: float, caption: str = "LfDTrack-v0") -> None:
        self._pygame = load_pygame()
        self.fps = fps
        self.caption = caption
        self._screen: Any = None
        self._clock: Any = None

    @property
    def is_open(self) -> bool:
        return self._screen is not None

    def show(self, rgb: np.ndarray) -> None:
        """Draw ``rgb`` (H, W, 3) uint8, opening (or resizing) the window as needed."""
        pygame = self._pygame
        height, width = rgb.shape[:2]
        if self._screen is None:
            pygame.display.init()
            pygame.display.set_caption(self.caption)
            self._clock = pygame.time.Clock()
        if self._screen is None or self._screen.get_size() != (width, height):
            self._screen = pygame.display.set_mode((width, height))
        surface = pygame.surfarray.make_surface(np.ascontiguousarray(rgb.transpose(1, 0, 2)))
        self._screen.blit(surface, (0, 0))
        pygame.event.pump()  # keeps the window responsive between pictures
        pygame.display.flip()
        self._clock.tick(self.fps)

    def close(self) -> None:
        """Close the window (nothing to do if it never opened)."""
        if self._screen is not None:
            self._pygame.display.quit()
            self._screen = None
            self._clock = None
