"""Screen tests of a corner's tip decision by decision against part 12's oracle (part 15 of
``README.md``).

A test a robot could run is worth a rule run (about 12 minutes) only if it changes the map rule's
commands where part 12's oracle changes them, and not elsewhere. This script drives the map rule
on the map as it is (``../generalization/rules.py``, its arguments passed on) and, at every frame,
lets copies of the map see the same frame with each test (and the oracle: ``oracle_visited.py
--combine cover --cover-from 0.3``) and reads the command the rule would give on each copy's
inputs (a pivot toward the bearing beyond 20 degrees, else forward; on a blank map the branch
side's pivot, or ``?`` without one: the rule's last side, which the copy does not know). Per
test it counts the frames where the map as it is and the oracle disagree and the test gives the
oracle's command (``fixed``), the frames where they agree and the test does not (``broken``),
and how many frames it changes at all. The counts are summed over the worker processes into
``--screen FILE`` (JSON). Every drive is the map as it is; nothing the copies see changes it.
``--tests a,b`` screens only those of :data:`TESTS`; ``--frames DIR`` keeps the maps of the frames
the oracle changes (pickled; ``frames.py`` reads them), and with ``--sample N`` every N-th frame's
too (counted per worker process, so which frames are sampled depends on ``--workers``). ``--drive NAME`` instead runs the rule on the map with the test NAME (a rule run).

    .venv/bin/python benchmarks/experiments/sharp_corners/screen.py --screen /tmp/screen.json --study benchmarks/experiments/human_goal/round27/balance.toml --condition rooms.round20+visual+balance --rule map-rule --map branch_side=true --map branch_window=commands --map motion=visual --map colour_balance=safe_box --repetitions 1 --out /tmp/screen --workers 2
"""

from __future__ import annotations

import copy
import json
import math
import os
import pickle
import sys
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import dead_ends  # noqa: E402
import oracle_visited  # noqa: E402
import tips  # noqa: E402

from lfd_track.policy.memory import BEHIND_M, FreshFeltMemory, fresh_bearing_rad  # noqa: E402

#: [deg] the map rule's turn (``FreshFeltRuleConfig.turn_deg``)
TURN_DEG = 20.0
COUNTS: dict[str, dict[str, int]] = {}
OUT: dict[str, Path | None] = {"file": None, "frames": None}
#: ``--sample N``: with ``--frames``, keep every N-th frame's map too (0: only those the oracle
#: changes)
SAMPLE = {"every": 0, "seen": 0}

#: ``islands``: fresh felt weighing at least ``ISLAND_MIN`` (felt level times how fresh) within
#: ``ISLAND_LOOK_M`` of the axle is joined into pieces by links of at most ``ISLAND_LINK_M``; a
#: piece none of whose points lies ``ISLAND_FAR_M`` or further from the axle leads nowhere.
ISLAND_MIN, ISLAND_LOOK_M, ISLAND_LINK_M, ISLAND_FAR_M = 0.1, 1.5, 0.15, 0.8


def islands(memory: FreshFeltMemory, chosen: np.ndarray) -> np.ndarray:
    """(K,) bool for the fresh felt points ``chosen`` (K,) int of ``memory``'s map: in a piece
    of fresh felt that ends within ``ISLAND_FAR_M`` of the axle."""
    points, felt = memory._points, memory._felt
    dist = np.hypot(points[:, 0], points[:, 1])
    where = (felt > 0.0) & (points[:, 0] > -BEHIND_M) & (dist < ISLAND_LOOK_M)
    kept = memory._kept(where)  # the map's own visited felt (a screened copy's is)
    if kept is None:
        return np.zeros(len(chosen), dtype=bool)
    idx = np.flatnonzero(felt * kept >= ISLAND_MIN)
    gap_x = points[idx, 0, None] - points[None, idx, 0]
    gap_y = points[idx, 1, None] - points[None, idx, 1]
    linked = gap_x * gap_x + gap_y * gap_y <= ISLAND_LINK_M**2
    piece = np.full(len(idx), -1)
    far: list[bool] = []
    for start in range(len(idx)):
        if piece[start] >= 0:
            continue
        piece[start] = len(far)
        reached = np.zeros(len(idx), dtype=bool)
        reached[start] = True
        frontier = reached.copy()
        while frontier.any():
            frontier = linked[frontier].any(axis=0) & ~reached
            reached |= frontier
        piece[reached] = len(far)
        far.append(bool(dist[idx[reached]].max() >= ISLAND_FAR_M))
    leads_on = np.zeros(len(points), dtype=bool)
    if len(idx):
        leads_on[idx[np.asarray(far, dtype=bool)[piece]]] = True
    return ~leads_on[chosen]


def end_blank(end_to_m: float) -> Callable[[FreshFeltMemory, np.ndarray], np.ndarray]:
    """A test leaving out all fresh felt while the branch side gives a side and the rover's own
    strip ends within ``end_to_m`` ahead (``dead_ends.strip_end_m``)."""

    def test(memory: FreshFeltMemory, chosen: np.ndarray) -> np.ndarray:
        ends = (
            memory._side != 0.5
            and dead_ends.strip_end_m(memory._points, memory._felt, end_to_m) is not None
        )
        return np.full(len(chosen), ends)

    return test


def side_sign(memory: FreshFeltMemory) -> float:
    """+1 where the branch side gives the left, -1 otherwise (the right, or no side)."""
    return 1.0 if memory._side > 0.5 else -1.0


#: [m] ``overlap_*``: felt beside the rover is looked for up to this far ahead of the axle
BESIDE_AHEAD_M = 0.4


def felt_beside(memory: FreshFeltMemory, near_m: float, far_m: float) -> bool:
    """Whether the map holds felt on the branch side's side between ``near_m`` and ``far_m``
    off the rover's heading, from just behind the axle to ``BESIDE_AHEAD_M`` ahead: at least
    ``dead_ends.MIN_SEEN`` points of mean felt level 0.5 or more (a second strip beside the
    rover's own)."""
    x, off = memory._points[:, 0], memory._points[:, 1] * side_sign(memory)
    band = (x >= -0.1) & (x <= BESIDE_AHEAD_M) & (off >= near_m) & (off <= far_m)
    seen = int(band.sum())
    return seen >= dead_ends.MIN_SEEN and float(memory._felt[band].mean()) >= 0.5


def overlap_blank(
    end_to_m: float, near_m: float, far_m: float
) -> Callable[[FreshFeltMemory, np.ndarray], np.ndarray]:
    """``end_blank``, and only while felt lies beside the rover on the branch side's side."""
    ends = end_blank(end_to_m)

    def test(memory: FreshFeltMemory, chosen: np.ndarray) -> np.ndarray:
        if memory._side == 0.5 or not felt_beside(memory, near_m, far_m):
            return np.zeros(len(chosen), dtype=bool)
        return ends(memory, chosen)

    return test


def contradicted(
    end_to_m: float, toward_deg: float
) -> Callable[[FreshFeltMemory, np.ndarray], np.ndarray]:
    """``end_blank``, and only while the fresh felt's bearing lies less than ``toward_deg``
    toward the branch side's side (straight ahead or to the other side: the map and the branch
    side disagree)."""
    ends = end_blank(end_to_m)

    def test(memory: FreshFeltMemory, chosen: np.ndarray) -> np.ndarray:
        if memory._side == 0.5:
            return np.zeros(len(chosen), dtype=bool)
        weights = memory._weights_now[chosen]  # type: ignore[attr-defined]
        x = float((weights * memory._points[chosen, 0]).sum())
        y = float((weights * memory._points[chosen, 1]).sum())
        if side_sign(memory) * math.degrees(math.atan2(y, x)) >= toward_deg:
            return np.zeros(len(chosen), dtype=bool)
        return ends(memory, chosen)

    return test


#: ``null_*``: the share of frames (per thousand) whose fresh felt is all left out by chance
NULL_PER_MILLE = 8


def null(salt: int) -> Callable[[FreshFeltMemory, np.ndarray], np.ndarray]:
    """A test aimed at nothing: every fresh felt left out at about ``NULL_PER_MILLE`` frames in a
    thousand, chosen by a checksum of the map's points with ``salt`` (the same frames on every
    run of the same drive), to measure how far changing a few dozen commands anywhere moves the
    laps."""

    def test(memory: FreshFeltMemory, chosen: np.ndarray) -> np.ndarray:
        drawn = zlib.crc32(memory._points.tobytes(), salt) % 1000 < NULL_PER_MILLE
        return np.full(len(chosen), drawn)

    return test


#: ``turned_*``: the rover's new leg is its path's last ``NEW_LEG_M`` of travel, its old leg the
#: travel from ``OLD_LEG_M[1]`` to ``OLD_LEG_M[0]`` back; places closer than ``SAME_PLACE_M``
#: (pivots) count once
NEW_LEG_M, OLD_LEG_M, SAME_PLACE_M = 0.3, (0.6, 1.0), 0.02


def places_back(path: np.ndarray, metres: tuple[float, ...]) -> list[np.ndarray] | None:
    """The places (2,) of ``path`` (N, 2; rover frame, oldest first) that the rover left the
    given ``metres`` of travel back from its own place (the origin), places closer than
    ``SAME_PLACE_M`` (pivots) counted once; None where it has not travelled that far yet."""
    places = [np.zeros(2)]
    for place in path[::-1]:
        if math.hypot(*(place - places[-1])) > SAME_PLACE_M:
            places.append(place)
    back = np.array(places)
    travelled = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(back, axis=0).T))])
    ends = np.searchsorted(travelled, metres)
    return None if ends.max() >= len(back) else [back[end] for end in ends]


def turned_back(angle_deg: float) -> Callable[[FreshFeltMemory, np.ndarray], np.ndarray]:
    """A test leaving out the fresh felt behind the rover along its new leg once its path has
    turned a corner: where the direction of its last ``NEW_LEG_M`` of travel and that of its
    old leg (``OLD_LEG_M``) differ by ``angle_deg`` or more, fresh felt lying behind the rover's
    place along the new leg (the corner it has turned, and the tip past it) leads back."""
    cos_turn = math.cos(math.radians(angle_deg))

    def test(memory: FreshFeltMemory, chosen: np.ndarray) -> np.ndarray:
        found = places_back(memory._path, (NEW_LEG_M, *OLD_LEG_M))
        if found is None:
            return np.zeros(len(chosen), dtype=bool)
        leg_start, old_end, old_start = found
        new = -leg_start / np.linalg.norm(leg_start)
        old = old_end - old_start
        if float(new @ old) > cos_turn * float(np.linalg.norm(old)):  # no corner turned
            return np.zeros(len(chosen), dtype=bool)
        return memory._points[chosen] @ new < 0.0

    return test


def retrace_side(memory: FreshFeltMemory, chosen: np.ndarray) -> np.ndarray:
    """While the branch side gives a side: the fresh felt behind the rover's place along the
    direction of its last ``NEW_LEG_M`` of travel and on the other side of that line than the
    branch side (the strip it came along, where it rode the branch side's edge), left out."""
    found = places_back(memory._path, (NEW_LEG_M,))
    if memory._side == 0.5 or found is None:
        return np.zeros(len(chosen), dtype=bool)
    came = -found[0] / np.linalg.norm(found[0])
    points = memory._points[chosen]
    across = came[0] * points[:, 1] - came[1] * points[:, 0]  # left of the line positive
    return (points @ came < 0.0) & (side_sign(memory) * across < 0.0)


TESTS: dict[str, Callable[[FreshFeltMemory, np.ndarray], np.ndarray]] = {
    "dead_ends": lambda m, chosen: dead_ends.leads_nowhere(m._points, m._felt, chosen),
    "whole_tip": lambda m, chosen: dead_ends.whole_tip(m._points, m._felt, chosen),
    "islands": islands,
    "end_blank_0.3": end_blank(0.3),
    "end_blank_0.45": end_blank(0.45),
    "end_blank_0.6": end_blank(0.6),
    "overlap_0.45_0.3-0.6": overlap_blank(0.45, 0.3, 0.6),
    "overlap_0.45_0.4-0.7": overlap_blank(0.45, 0.4, 0.7),
    "overlap_0.6_0.3-0.6": overlap_blank(0.6, 0.3, 0.6),
    "overlap_0.6_0.4-0.7": overlap_blank(0.6, 0.4, 0.7),
    "overlap_0.6_0.5-0.8": overlap_blank(0.6, 0.5, 0.8),
    "contra_0.45_-5": contradicted(0.45, -5.0),
    "contra_0.6_-5": contradicted(0.6, -5.0),
    "contra_0.6_0": contradicted(0.6, 0.0),
    "contra_0.8_-5": contradicted(0.8, -5.0),
    "overlap_or_contra": lambda m, chosen: (
        TESTS["overlap_0.45_0.4-0.7"](m, chosen) | TESTS["contra_0.45_-5"](m, chosen)
    ),
    "turned_60": turned_back(60.0),
    "retrace_side": retrace_side,
    "null_1": null(1),
    "null_2": null(2),
}


def side_behind(
    off_m: float, back_m: float, own_strip: bool = True
) -> Callable[[FreshFeltMemory, np.ndarray], np.ndarray]:
    """A test adding felt to what counts (part 35): while the branch side gives a side, the map's
    points behind the axle (from ``BEHIND_M`` to ``back_m`` back) and at least ``off_m`` to that
    side, within the reach ``near`` (N,) bool, count as ahead (on the rover's own strip too, with
    ``own_strip``), so that fresh felt there (a sharp corner's outgoing strip, running back
    beside the rover) pulls the bearing toward the side; the map's visited felt and fresh sight
    still apply."""

    def extra(memory: FreshFeltMemory, near: np.ndarray) -> np.ndarray:
        if memory._side == 0.5:  # no side
            return np.zeros(len(near), dtype=bool)
        sign = side_sign(memory)
        x, y = memory._points[:, 0], memory._points[:, 1]
        added = near & (x <= -BEHIND_M) & (x > -back_m) & (sign * y >= off_m)
        if own_strip and added.any():
            added &= memory._own_strip(np.hypot(x, y))
        return added

    return extra


#: tests that add felt to the fresh felt instead of leaving some out (part 35): the points of
#: the map that count as ahead besides those the map counts
EXTRA: dict[str, Callable[[FreshFeltMemory, np.ndarray], np.ndarray]] = {
    "side_behind_0.15": side_behind(0.15, 0.45),
    "side_behind_0.25": side_behind(0.25, 0.45),
    "side_behind_0.35": side_behind(0.35, 0.45),
    "side_behind_0.25_any_strip": side_behind(0.25, 0.45, own_strip=False),
}

#: the tests a screen run scores (``--tests a,b``; default all but :data:`EXTRA`)
SCREENED: list[str] = list(TESTS)


def command(inputs: np.ndarray, range_deg: float) -> str:
    """The map rule's command on the map's ``inputs`` (see the module docstring)."""
    if float(inputs[1]) <= 0.0:
        side = float(inputs[3]) if len(inputs) > 3 else 0.5
        return "L" if side > 0.5 else "R" if side < 0.5 else "?"
    bearing = fresh_bearing_rad(inputs, range_deg)
    limit = math.radians(TURN_DEG)
    return "L" if bearing > limit else "R" if bearing < -limit else "F"


class ScreenMemory(oracle_visited.TrackVisitedMemory):
    """The map as it is, whose copies see each frame with each test and the oracle."""

    _test: str | None = None

    def __copy__(self) -> ScreenMemory:
        twin = object.__new__(type(self))
        twin.__dict__.update(self.__dict__)
        if self._branch is not None:
            twin._branch = copy.copy(self._branch)
        return twin

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        if self._test == "oracle":
            return super()._kept(where)
        return super(oracle_visited.TrackVisitedMemory, self)._kept(where)  # the map's own

    def _fresh(self, near: np.ndarray, ahead: np.ndarray) -> np.ndarray:
        if self._test in EXTRA:
            ahead = ahead | EXTRA[self._test](self, near)
        weights = super()._fresh(near, ahead)
        if self._test in TESTS:
            chosen = np.flatnonzero(weights > 0.0)
            if len(chosen):
                self._weights_now = weights
                weights[chosen[TESTS[self._test](self, chosen)]] = 0.0
        return weights

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        if self._test is not None:
            super().see(values, levels)
            return
        range_deg = self.config.bearing_range_deg
        said = {}
        for name in ("oracle", *SCREENED):
            twin = copy.copy(self)
            twin._test = name
            twin.see(values, levels)
            said[name] = command(twin.inputs(), range_deg)
        super().see(values, levels)
        as_is, oracle = command(self.inputs(), range_deg), said["oracle"]
        SAMPLE["seen"] += 1
        sampled = SAMPLE["every"] > 0 and SAMPLE["seen"] % SAMPLE["every"] == 0
        if OUT["frames"] is not None and (as_is != oracle or sampled):
            self._keep_frame(as_is, said)
        for name, said_now in said.items():
            counts = COUNTS.setdefault(
                name, {"frames": 0, "oracle_differs": 0, "fixed": 0, "broken": 0, "changed": 0}
            )
            counts["frames"] += 1
            counts["oracle_differs"] += as_is != oracle
            counts["fixed"] += as_is != oracle and said_now == oracle
            counts["broken"] += as_is == oracle and said_now != oracle
            counts["changed"] += said_now != as_is
        folder = OUT["file"]
        assert folder is not None
        with open(f"{folder}.{os.getpid()}", "w") as out:
            json.dump(COUNTS, out)

    def _keep_frame(self, as_is: str, said: dict[str, str]) -> None:
        """Keep this frame's map for ``--frames`` (pickled per worker process)."""
        now = oracle_visited.NOW
        weights = self._fresh(  # the map as it is: this instance screens, it tests nothing
            np.hypot(self._points[:, 0], self._points[:, 1]) < self.config.reach_m,
            self._points[:, 0] > -BEHIND_M,
        )
        chosen = np.flatnonzero(weights > 0.0)
        floor = oracle_visited.to_floor(self._points[chosen], now["pose"])
        ahead = oracle_visited.track_ahead(now["track"], floor, now["progress_m"], tips.BEHIND_M)
        frame = tips.moment(self, chosen, weights[chosen], ~ahead)
        frame.update(side=self._side, as_is=as_is, said=said, inputs=self.inputs())
        folder = OUT["frames"]
        assert folder is not None
        with open(folder / f"frames_{os.getpid()}.pkl", "ab") as out:  # one record a frame
            pickle.dump(frame, out)


class DriveMemory(ScreenMemory):
    """The map with one test (``--drive``), seeing each frame once."""


def drive(name: str) -> None:
    """Run ``../generalization/rules.py`` (this script's arguments) with the map rule driving on
    the map with the test ``name`` (a key of :data:`TESTS`)."""
    if name not in TESTS and name not in EXTRA:
        raise SystemExit(f"--drive takes one of: {', '.join([*TESTS, *EXTRA])}")

    DriveMemory._test = name
    oracle_visited.map_rule_with(DriveMemory)


def main() -> None:
    if "--tests" in sys.argv:
        at = sys.argv.index("--tests")
        names = sys.argv[at + 1].split(",")
        unknown = [n for n in names if n not in TESTS and n not in EXTRA]
        if unknown:
            known = ", ".join([*TESTS, *EXTRA])
            raise SystemExit(f"--tests: no test {', '.join(unknown)}; there are {known}")
        SCREENED[:] = names
        del sys.argv[at : at + 2]
    if "--drive" in sys.argv:
        at = sys.argv.index("--drive")
        name = sys.argv[at + 1]
        del sys.argv[at : at + 2]
        drive(name)
        return
    if "--frames" in sys.argv:
        at = sys.argv.index("--frames")
        frames = OUT["frames"] = Path(sys.argv[at + 1])
        frames.mkdir(parents=True, exist_ok=True)
        for old in frames.glob("frames_*.pkl"):
            old.unlink()
        del sys.argv[at : at + 2]
    if "--sample" in sys.argv:
        at = sys.argv.index("--sample")
        SAMPLE["every"] = int(sys.argv[at + 1])
        del sys.argv[at : at + 2]
    at = sys.argv.index("--screen")
    target = OUT["file"] = Path(sys.argv[at + 1])
    del sys.argv[at : at + 2]
    for old in target.parent.glob(f"{target.name}.*"):
        old.unlink()
    oracle_visited.NOW["combine"], oracle_visited.NOW["cover_from_m"] = "cover", 0.3
    oracle_visited.main(ScreenMemory)
    total: dict[str, Any] = {}
    for part in sorted(target.parent.glob(f"{target.name}.*")):
        for name, counts in json.loads(part.read_text()).items():
            for key, value in counts.items():
                total.setdefault(name, {}).setdefault(key, 0)
                total[name][key] += value
        part.unlink()
    target.write_text(json.dumps(total, indent=1) + "\n")
    for name, counts in total.items():
        print(name, counts)


if __name__ == "__main__":
    main()
