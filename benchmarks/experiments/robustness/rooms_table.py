"""The rooms table (README.md, part 2): each condition of ``rooms.toml`` pooled, and each room.

Reads ``results/rooms/<condition>/seed<k>/results.json`` and writes ``results/rooms_table.md``:
per condition, procedural test-loop laps and testing-track laps with 95 % Wilson intervals and
the loops by sharpest turn; per repetition of a ``rooms.*`` condition (one room each), its loop
and testing laps beside the room's drawn camera, rover and light (the room is drawn again from
the repetition's seed exactly as the run drew it, ``runner.repetition_preset``); and the verdict
of the rule written before the run.

    .venv/bin/python benchmarks/experiments/robustness/rooms_table.py
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from lfd_track.benchmark.config import BenchmarkConfig
from lfd_track.benchmark.runner import repetition_preset, repetition_seeds
from lfd_track.study.stats import rate_summary
from lfd_track.utils.atomic import atomic_write_text

HERE = Path(__file__).resolve().parent
STUDY = HERE / "results" / "rooms"
OUT = HERE / "results" / "rooms_table.md"
BINS = ("60-100", "100-135", ">135")
GOAL = 0.85  # every room: at least 85 % of its loop laps


def _rate(ok: int, n: int) -> str:
    if not n:
        return "–"
    r = rate_summary(ok, n)
    low, high = r["ci95"]
    return f"{ok}/{n} = {100 * ok / n:.0f} % [{100 * low:.0f}–{100 * high:.0f}]"


def _jobs(condition: str) -> list[dict[str, Any]]:
    return [
        json.loads(p.read_text(encoding="utf-8"))
        for p in sorted((STUDY / condition).glob("seed*/results.json"))
    ]


def _laps(outcomes: list[dict[str, Any]], loops: bool, rep: int | None = None) -> tuple[int, int]:
    chosen = [
        o
        for o in outcomes
        if o["track"].startswith("random:") == loops
        and (loops or o["track"] == "testing")
        and (rep is None or o["repetition"] == rep)
    ]
    return sum(bool(o["success"]) for o in chosen), len(chosen)


def _room(job: dict[str, Any], rep: int) -> str:
    config = BenchmarkConfig.from_dict(job["config"])
    seed = repetition_seeds(job["seed"], config.repetitions)[rep]
    room = repetition_preset(config, seed)
    cam, rover, light = room.camera, room.rover, room.lighting
    felt = tuple(int(c) for c in room.appearance.felt_rgb)
    carpet = tuple(int(c) for c in room.appearance.carpet_rgb)
    return (
        f"camera {cam.height_m:.3f} m, {cam.pitch_deg:.1f}°, vfov {cam.vfov_deg:.0f}°;"
        f" slip {rover.slip_noise_std:.3f}, motors ±{rover.motor_asymmetry_std:.3f};"
        f" felt {felt}, carpet {carpet}, ambient {light.ambient:.2f}"
    )


def main() -> None:
    conditions = sorted(p.name for p in STUDY.iterdir() if p.is_dir())
    lines = [
        "# Rooms: the chosen configuration taught and driven in other worlds",
        "",
        "| condition | test loops | " + " | ".join(f"sharpest {b}°" for b in BINS) + " |"
        " testing track | repetitions without a controller |",
        "|---|---|" + "---|" * len(BINS) + "---|---|",
    ]
    pooled: dict[str, tuple[int, int]] = {}
    for condition in conditions:
        jobs = _jobs(condition)
        outcomes = [o for j in jobs for o in j["outcomes"]]
        loops = _laps(outcomes, True)
        pooled[condition] = loops
        bins = []
        for b in BINS:
            ok = sum(j["random_loops"]["by_sharpest_turn"][b]["successes"] for j in jobs)
            n = sum(j["random_loops"]["by_sharpest_turn"][b]["laps"] for j in jobs)
            bins.append(_rate(ok, n))
        failed = [
            f"seed {j['seed']} rep. {f['repetition']}: {f['failed']}"
            for j in jobs
            for f in j.get("failed_repetitions", [])
        ]
        lines.append(
            f"| {condition} | {_rate(*loops)} | " + " | ".join(bins) + f" |"
            f" {_rate(*_laps(outcomes, False))} | {'; '.join(failed) or 'none'} |"
        )
    lines += ["", "## Each room", ""]
    lines += ["| condition | seed | repetition | test loops | testing track | the room |"]
    lines += ["|---|---|---|---|---|---|"]
    verdict: dict[str, bool] = {}
    for condition in conditions:
        if not condition.startswith("rooms."):
            continue
        every = True
        for job in _jobs(condition):
            for rep in range(job["config"]["repetitions"]):
                ok, n = _laps(job["outcomes"], True, rep)
                every &= n > 0 and ok / n >= GOAL
                lines.append(
                    f"| {condition} | {job['seed']} | {rep} | {_rate(ok, n)} |"
                    f" {_rate(*_laps(job['outcomes'], False, rep))} | {_room(job, rep)} |"
                )
        verdict[condition] = every
    lines += ["", "## The rule's verdict", ""]
    for variant in ("chosen", "chosen+levels"):
        rooms_ok = verdict.get(f"rooms.{variant}", False)
        ours, paper = pooled.get(f"randomized.{variant}"), pooled.get("randomized.paper")
        ahead = bool(ours and paper and ours[0] / ours[1] > paper[0] / paper[1])
        lines.append(
            f"- `{variant}`: every room at least {GOAL:.0%} of its loop laps:"
            f" {'yes' if rooms_ok else 'no'}; a new room every episode, ahead of the paper"
            f" pipeline: {'yes' if ahead else 'no'}; goal {'met' if rooms_ok and ahead else 'not met'}."
        )
    text = "\n".join(lines) + "\n"
    atomic_write_text(OUT, text)
    print(text)


if __name__ == "__main__":
    main()
