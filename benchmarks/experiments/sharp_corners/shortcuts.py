"""Do the map rule's lost laps leave their strip for another part of the same loop? (part 21 of
``README.md``)

Reads the whole-lap poses ``margins.py`` writes (``events.jsonl``: one lap per pair of lines) and
replays each lost lap through the episode's own progress (``lfd_track.world.episode``), in the
direction in which its progress grows. A lap takes a **shortcut** at the first pose where the
rover stands off the felt of the strip its progress is on (farther than half a width plus
``OFF_M`` from the centreline point at its progress) and on the felt of a part of the loop more
than ``APART_M`` of track away from that point (within half a width of it): it crossed the
carpet between two parts of the loop that pass near each other (the track files allow strips
one width apart, centre to centre, so their edges may touch). Such a lap is lost where the
rover left its strip, whatever corner the episode later charges. It chooses nothing.

    .venv/bin/python benchmarks/experiments/sharp_corners/shortcuts.py benchmarks/experiments/sharp_corners/results/margins/rooms_0.3/events.jsonl
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import margins  # noqa: E402

from lfd_track.world.episode import EpisodeTracker  # noqa: E402
from lfd_track.world.track import Track, load_track  # noqa: E402

#: [m] off its own strip: this far beyond the strip's half width from the progress point
OFF_M = 0.05
#: [m] another part of the loop: this much track or more from the progress point, either way
APART_M = 1.0
#: [m] a shortcut to the track at most this far ahead cuts a short leg (else it leaves for
#: another part of the loop)
SHORT_CUT_M = 2.0


def replay(track: Track, poses: np.ndarray) -> list[float]:
    """The episode's progress [m] at each of ``poses`` (the first is reset to)."""
    tracker = EpisodeTracker(track)
    tracker.reset(poses[0], (True, True))
    progress = [tracker.state.progress_m]
    for pose in poses[1:]:
        progress.append(tracker.update(pose, (True, True)).progress_m)
        if tracker.state.failure is not None:
            break
    return progress


def driven(name: str, poses: np.ndarray) -> tuple[Track, list[float]]:
    """The loop ``name`` in the direction the rover drove it (its progress grows over the first
    metre), and the progress at each pose."""
    runs = []
    for reverse in (False, True):
        track = load_track(name, reverse=reverse)
        progress = replay(track, poses)
        runs.append((len(progress), progress[min(10, len(progress) - 1)], track, progress))
    _, _, track, progress = max(runs, key=lambda run: (run[0], run[1]))
    return track, progress


def shortcut(track: Track, poses: np.ndarray, progress: list[float]) -> dict[str, Any] | None:
    """The first pose where the rover stands on another part of the loop, or None."""
    half = 0.5 * track.width_m
    length = track.length_m
    for i, s in enumerate(progress):
        place = poses[i, :2]
        own, _ = track.point_at(s)
        if math.dist(place, own) <= half + OFF_M:
            continue
        on = track.project(place)  # (S, 2): arc length and distance per segment
        for at, distance in on:
            apart = abs((at - s + 0.5 * length) % length - 0.5 * length)
            if distance <= half and apart > APART_M:
                return {"pose": i, "progress_m": s, "onto_m": float(at), "gap_m": gap(track, s, at)}
    return None


def gap(track: Track, here_m: float, there_m: float, around_m: float = 0.5) -> float:
    """[m] the carpet between the strip around ``here_m`` and the strip around ``there_m``
    (``around_m`` of track either way of each): their centrelines' least distance less one
    width (0 or less: the strips touch or overlap; for a short leg cut, the windows take in the
    leg's own corner and this reads below 0)."""
    steps = np.linspace(-around_m, around_m, 51)
    here = np.array([track.point_at(here_m + d)[0] for d in steps])
    there = np.array([track.point_at(there_m + d)[0] for d in steps])
    least = np.hypot(*(here[:, None, :] - there[None, :, :]).transpose(2, 0, 1)).min()
    return float(least) - track.width_m


def main() -> None:
    laps = margins.read_laps(Path(sys.argv[1]))
    kinds: dict[str, int] = {}
    gaps: dict[str, list[float]] = {}
    for lap in sorted(laps.values(), key=lambda lap: lap["lap"]):
        if lap.get("end") == "lapped" or "poses" not in lap:
            continue
        poses = np.asarray(lap["poses"])
        track, progress = driven(lap["track"], poses)
        found = shortcut(track, poses, progress)
        if found is None:
            vertex = margins.vertex_of(lap["track"], lap["corner"])
            near = math.dist(lap["pose"][:2], vertex) <= margins.NEAR_VERTEX_M
            kind = "turned round at a corner" if near else "lost elsewhere on its strip"
        else:
            ahead = (found["onto_m"] - found["progress_m"]) % track.length_m
            kind = (
                f"a shortcut across to the track up to {SHORT_CUT_M:g} m ahead (a short leg cut)"
                if ahead <= SHORT_CUT_M
                else f"a shortcut onto a part of the loop further than {SHORT_CUT_M:g} m away"
            )
            gaps.setdefault(kind, []).append(found["gap_m"])
        kinds[kind] = kinds.get(kind, 0) + 1
    print("| how the lap was lost | laps | carpet between the two strips [m] |")
    print("|---|---|---|")
    for kind, count in sorted(kinds.items()):
        between = ", ".join(f"{g:.2f}" for g in sorted(gaps.get(kind, []))) or "–"
        print(f"| {kind} | {count} | {between} |")


if __name__ == "__main__":
    main()
