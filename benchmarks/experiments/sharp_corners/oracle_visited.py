"""The map rule with the map's visited felt told by the track itself: does that binding lift the
sharp corners? (part 8 of ``README.md``)

Drives ``../generalization/rules.py`` unchanged (its arguments are passed on) with one change
to the ``fresh_felt`` map: which felt counts as visited. The map measures it from the places the
rover's axle has been (felt within ``path_radius_m`` of them, faded over ``visited_fade_m``);
here a felt point of the map is fresh exactly when the track's centreline nearest to where it
lies on the floor is still ahead of the rover along the track (the rover's progress, as the
episode measures it), and visited when it is behind. Where the map places its points is its own
(dead reckoning or the measured motion); they are carried to the floor by the rover's true pose.
At a hairpin the outgoing strip then stays fresh however close it runs to the incoming one, and
the incoming strip is visited across its whole width. Everything else (the camera, the road
library, the strip links, the reach, the branch side, the rule) is the map rule's own.

This is an oracle, for a measurement only: a robot does not know the track.

``--combine`` (part 10) splits what the oracle changes in two, each with the map's own visited
felt kept elsewhere: ``unhide`` makes fresh what the track says is ahead although the map counts
it visited (the outgoing strip beside the incoming one, the corner's tip), and nothing else;
``cover`` makes visited what the track says is behind although the map counts it fresh (the far
half of a strip ridden along one edge), and nothing else. The default, ``oracle``, is part 8's.
``--cover-from M`` (part 12, with ``cover``) covers only felt whose centreline lies at least M
metres of track behind the rover's progress: what a map marking the felt abeam behind the axle
could cover at best.

    .venv/bin/python benchmarks/experiments/sharp_corners/oracle_visited.py --study benchmarks/experiments/human_goal/round27/balance.toml --condition rooms.round20+visual+balance --rule map-rule --map branch_side=true --map branch_window=commands --map motion=visual --map colour_balance=safe_box --out benchmarks/experiments/sharp_corners/results/oracle_visited/rooms --workers 2
"""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.policy.memory import FreshFeltConfig, FreshFeltMemory, memory_for
from lfd_track.teaching import perception as perception_module
from lfd_track.world.track import Track

HERE = Path(__file__).resolve().parent
RULES_PY = HERE.parent / "generalization" / "rules.py"

#: The episode the map sees now: its track, the rover's pose and progress after the last step;
#: and how the track's visited felt combines with the map's own (``--combine``).
NOW: dict[str, Any] = {
    "track": None,
    "pose": None,
    "progress_m": 0.0,
    "combine": "oracle",
    "cover_from_m": 0.0,
}
COMBINES = ("oracle", "unhide", "cover")


def _remember(env: LfDTrackEnv, info: dict[str, Any]) -> None:
    NOW["track"], NOW["pose"], NOW["progress_m"] = env.track, info["pose"], info["progress_m"]


_reset, _step = LfDTrackEnv.reset, LfDTrackEnv.step


def reset(self: LfDTrackEnv, **kw: Any) -> Any:
    frame, info = _reset(self, **kw)
    _remember(self, info)
    return frame, info


def step(self: LfDTrackEnv, action: int) -> Any:
    out = _step(self, action)
    _remember(self, out[4])
    return out


def centreline_at(track: Track, floor: np.ndarray) -> np.ndarray:
    """(N,) [m]: the arc length along ``track`` of the centreline nearest each floor point
    (N, 2)."""
    projected = track.project(floor)  # (N, S, 2): each point's arc length and distance
    nearest = np.argmin(projected[..., 1], axis=1)
    return projected[np.arange(len(floor)), nearest, 0]


def track_ahead(
    track: Track, floor: np.ndarray, progress_m: float, behind_m: float = 0.0
) -> np.ndarray:
    """(N,) bool: whether the centreline nearest each floor point (N, 2) lies ahead of
    ``progress_m`` along ``track`` (on a loop: within half its length ahead), or less than
    ``behind_m`` behind it."""
    s = centreline_at(track, floor)
    if not track.closed:
        return s > progress_m - behind_m
    ahead = (s - progress_m + behind_m) % track.length_m
    return (ahead > 0.0) & (ahead < 0.5 * track.length_m + behind_m)


def to_floor(points: np.ndarray, pose: tuple[float, float, float]) -> np.ndarray:
    """(N, 2) floor points [m] of map points ``points`` (N, 2) in the frame of a rover at
    ``pose`` (x, y, heading)."""
    x, y, heading = pose
    cos, sin = math.cos(heading), math.sin(heading)
    return np.column_stack(
        [x + cos * points[:, 0] - sin * points[:, 1], y + sin * points[:, 0] + cos * points[:, 1]]
    )


class TrackVisitedMemory(FreshFeltMemory):
    """The ``fresh_felt`` map whose visited felt is the track's behind the rover."""

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        if NOW["track"] is None or not where.any():
            return super()._kept(where)
        floor = to_floor(self._points[where], NOW["pose"])
        kept = np.zeros(len(self._points))
        behind_m = NOW["cover_from_m"] if NOW["combine"] == "cover" else 0.0
        kept[where] = track_ahead(NOW["track"], floor, NOW["progress_m"], behind_m)
        if NOW["combine"] == "oracle":
            return kept
        own = super()._kept(where)
        if own is None:  # the map has no visited felt yet: nothing to cover, all fresh
            own = np.where(where, 1.0, 0.0)
        return np.maximum(own, kept) if NOW["combine"] == "unhide" else np.minimum(own, kept)


def worker_file(flag: str) -> Path:
    """The file named after ``flag`` on the command line (taken out of ``sys.argv``), whose
    workers write their parts as ``FILE.<pid>``: its folder made, old parts removed."""
    at = sys.argv.index(flag)
    path = Path(sys.argv[at + 1])
    del sys.argv[at : at + 2]
    path.parent.mkdir(parents=True, exist_ok=True)
    for old in path.parent.glob(f"{path.name}.*"):
        old.unlink()
    return path


def map_rule_with(memory_class: type[FreshFeltMemory]) -> None:
    """Run ``../generalization/rules.py`` (its arguments are this script's) with every
    ``fresh_felt`` map made as ``memory_class``."""
    maps_made_as(memory_class)
    load_rules().main()


def maps_made_as(memory_class: type[FreshFeltMemory]) -> None:
    """From now on, every ``fresh_felt`` map the rules' perception makes is a ``memory_class``."""

    def made(config: Any, geometry: Any = None) -> Any:
        if isinstance(config, FreshFeltConfig):
            return memory_class(config, geometry)
        return memory_for(config, geometry)

    perception_module.memory_for = made  # type: ignore[assignment]


def load_rules() -> Any:
    """``../generalization/rules.py`` as a module named ``rules``, to run as if it were the
    script (its arguments are this script's)."""
    spec = importlib.util.spec_from_file_location("rules", RULES_PY)
    assert spec is not None and spec.loader is not None
    rules = importlib.util.module_from_spec(spec)
    sys.modules["rules"] = rules  # the pool's workers (forked) find its functions by this name
    spec.loader.exec_module(rules)
    sys.argv[0] = str(RULES_PY)
    return rules


def main(memory_class: type[FreshFeltMemory] = TrackVisitedMemory) -> None:
    """The map rule with ``memory_class``'s map, the episode's track and pose kept in
    :data:`NOW` (``tips.py`` passes its own map)."""
    if "--combine" in sys.argv:
        at = sys.argv.index("--combine")
        NOW["combine"] = sys.argv[at + 1]
        if NOW["combine"] not in COMBINES:
            raise SystemExit(f"--combine must be one of {', '.join(COMBINES)}")
        del sys.argv[at : at + 2]
    if "--cover-from" in sys.argv:
        at = sys.argv.index("--cover-from")
        NOW["cover_from_m"] = float(sys.argv[at + 1])
        if NOW["combine"] != "cover" or not NOW["cover_from_m"] >= 0.0:
            raise SystemExit("--cover-from takes metres >= 0, with --combine cover")
        del sys.argv[at : at + 2]
    LfDTrackEnv.reset, LfDTrackEnv.step = reset, step  # type: ignore[method-assign]
    map_rule_with(memory_class)


if __name__ == "__main__":
    main()
