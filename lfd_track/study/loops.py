"""A condition's laps of procedural loops, pooled: the ``random_loops`` entry of study.json and its
table in study.md (the loops themselves: :mod:`lfd_track.world.loops`; how a job draws and admits
them: :mod:`lfd_track.benchmark.loops`).

Pooled over the condition's seeds and repetitions: the rate with its Wilson interval and the
interval that resamples whole controllers, the same by the loop's sharpest turn
(:data:`~lfd_track.world.loops.TURN_BINS`) and by strip width
(:data:`~lfd_track.world.loops.WIDTH_BINS`), and the share of drawn loops the teacher's check
excluded.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ..benchmark.loops import is_drawn_loop, loop_facts
from ..world.loops import TURN_BIN_LABELS, WIDTH_BIN_LABELS, turn_bin, width_bin
from .spec import Job
from .stats import controller_interval, rate_summary


def random_loops_summary(
    jobs: Sequence[tuple[Job, Mapping[str, Any]]], test_tracks: Sequence[str] = ()
) -> dict[str, Any] | None:
    """The condition's laps of procedural loops drawn per repetition (not those among its named
    ``test_tracks``), pooled; None if its jobs lapped none."""
    laps = [
        (job.seed, o)
        for job, r in jobs
        for o in r["outcomes"]
        if is_drawn_loop(str(o["track"]), test_tracks)
    ]
    if not laps:
        return None
    facts = {name: loop_facts(name) for name in sorted({str(o["track"]) for _, o in laps})}
    per_controller: dict[tuple[int, int], list[int]] = {}
    for seed, o in laps:
        group = per_controller.setdefault((seed, int(o["repetition"])), [0, 0])
        group[0] += bool(o["success"])
        group[1] += 1

    def pooled(selected: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
        return rate_summary(sum(bool(o["success"]) for o in selected), len(selected))

    outcomes = [o for _, o in laps]
    summary = pooled(outcomes)
    summary["ci95_controllers"] = controller_interval([(k, n) for k, n in per_controller.values()])
    turns: dict[str, list[Mapping[str, Any]]] = {label: [] for label in TURN_BIN_LABELS}
    widths: dict[str, list[Mapping[str, Any]]] = {label: [] for label in WIDTH_BIN_LABELS}
    for o in outcomes:
        sharpest, width = facts[str(o["track"])]
        turns[turn_bin(sharpest)].append(o)
        widths[width_bin(width)].append(o)
    sections = [r.get("random_loops", {}) for _, r in jobs]
    drawn = sum(int(s.get("drawn", 0)) for s in sections)
    excluded = sum(len(s.get("excluded", [])) for s in sections)
    splits = sorted({str(r.get("config", {}).get("random_split", "?")) for _, r in jobs})
    return {
        "split": ", ".join(splits),
        "loops": len(facts),
        "laps": summary,
        "by_sharpest_turn": {label: pooled(v) | {"loops": _loops(v)} for label, v in turns.items()},
        "by_width": {label: pooled(v) | {"loops": _loops(v)} for label, v in widths.items()},
        "drawn": drawn,
        "excluded": excluded,
    }


def _loops(outcomes: Sequence[Mapping[str, Any]]) -> int:
    return len({str(o["track"]) for o in outcomes})


def random_loops_markdown(conditions: Sequence[Mapping[str, Any]], cell: Any) -> list[str]:
    """study.md's table of procedural-loop laps (no lines when no condition lapped any);
    ``cell(rate)`` formats one rate as the summary's other tables do."""
    rows = [c for c in conditions if c.get("random_loops")]
    if not rows:
        return []
    turn_labels, width_labels = TURN_BIN_LABELS, WIDTH_BIN_LABELS
    lines = [
        "",
        "Procedural loops (each lapped once each way; a loop counts only once the scripted human "
        "laps it both ways in the same worlds), pooled and by the loop's sharpest turn "
        "(degrees):",
        "",
        "| condition | split | loops | all laps | "
        + " | ".join(f"sharpest {label}" for label in turn_labels)
        + " | excluded by the teacher |",
        "|---|---|---|---|" + "---|" * len(turn_labels) + "---|",
    ]
    for c in rows:
        loops = c["random_loops"]
        share = f"{loops['excluded']}/{loops['drawn']}" if loops["drawn"] else "–"
        lines.append(
            f"| {c['name']} | {loops['split']} | {loops['loops']} | {cell(loops['laps'])} | "
            + " | ".join(_binned(cell, loops["by_sharpest_turn"][x]) for x in turn_labels)
            + f" | {share} |"
        )
    lines += [
        "",
        "The same laps by strip width (m):",
        "",
        "| condition | " + " | ".join(width_labels) + " |",
        "|---|" + "---|" * len(width_labels),
    ]
    for c in rows:
        by_width = c["random_loops"]["by_width"]
        lines.append(
            f"| {c['name']} | "
            + " | ".join(_binned(cell, by_width[x]) for x in width_labels)
            + " |"
        )
    return lines


def _binned(cell: Any, rate: Mapping[str, Any]) -> str:
    return "–" if not rate["trials"] else f"{cell(rate)} ({rate['loops']} loops)"
