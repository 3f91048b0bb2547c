"""Tables of the limits experiment's part 4 (DAgger with a noise-free labeller) from committed results.

Reads ``results/dagger/<condition>/seed<k>/results.json`` and, for comparison, the committed
``paper``, ``hg-dagger`` and ``bc`` rows of ``benchmarks/experiments/beyond_the_paper/results/bilinear/``;
prints markdown: laps per loop and direction, the unseen loops pooled with 95 % Wilson intervals,
the learning curve per round, and human effort with robot seconds per repetition. Run from the repository root:

    python benchmarks/experiments/limits/dagger_tables.py
"""

from __future__ import annotations

import sys
from pathlib import Path

from lfd_track.benchmark.schema import read_results
from lfd_track.study.stats import wilson_interval

HERE = Path(__file__).resolve().parent
DAGGER = HERE / "results" / "dagger"
BEYOND = HERE.parent / "beyond_the_paper" / "results" / "beyond_the_paper"
CONDITIONS = ("dagger.ga.40-5-3", "dagger.bc.40-5-3", "dagger.bc.40-20-3")
COMPARED = ("paper", "hg-dagger", "bc")
LOOPS = ("training", "testing", "kite", "sbend", "notch", "bolt", "step")
UNSEEN = ("notch", "bolt", "step")


def _jobs(folder: Path) -> list[dict]:
    return [read_results(p) for p in sorted(folder.glob("seed*/results.json"))]


def _laps(jobs: list[dict], track: str, direction: str | None = None) -> tuple[int, int]:
    outcomes = [
        o
        for job in jobs
        for o in job["outcomes"]
        if o["track"] == track and (direction is None or o["direction"] == direction)
    ]
    return sum(o["success"] for o in outcomes), len(outcomes)


def _rate(wins: int, n: int) -> str:
    if n == 0:
        return "–"
    lo, hi = wilson_interval(wins, n)
    return f"{wins}/{n} = {100 * wins / n:.0f} % [{100 * lo:.0f}–{100 * hi:.0f}]"


def _directions(jobs: list[dict], track: str) -> list[str]:
    seen: list[str] = []
    for job in jobs:
        for o in job["outcomes"]:
            if o["track"] == track and o["direction"] not in seen:
                seen.append(o["direction"])
    return seen


def main() -> int:
    rows = [(c, _jobs(DAGGER / c)) for c in CONDITIONS]
    rows = [(c, jobs) for c, jobs in rows if jobs]
    compared = [(c, _jobs(BEYOND / c)) for c in COMPARED]
    print("| condition | " + " | ".join(LOOPS) + " | unseen notch/bolt/step |")
    print("|---|" + "---|" * (len(LOOPS) + 1))
    for name, jobs in [*rows, *compared]:
        cells = []
        for track in LOOPS:
            parts = [
                f"{w}/{n}" for w, n in (_laps(jobs, track, d) for d in _directions(jobs, track))
            ]
            cells.append(" + ".join(parts) if parts else "–")
        pooled = [_laps(jobs, t) for t in UNSEEN]
        wins, n = sum(w for w, _ in pooled), sum(n for _, n in pooled)
        print(f"| {name} | " + " | ".join(cells) + f" | {_rate(wins, n)} |")
    print()
    print("| condition | testing (both ways) | training (both ways) |")
    print("|---|---|---|")
    for name, jobs in [*rows, *compared]:
        print(f"| {name} | {_rate(*_laps(jobs, 'testing'))} | {_rate(*_laps(jobs, 'training'))} |")
    print()
    print("Learning curve (mean over jobs): cases, labels, corrections, unaided runs of 2,")
    print("label agreement, training accuracy per round")
    print()
    print(
        "| condition | round | cases | labels | corrections | unaided runs | agreement | accuracy |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, jobs in rows:
        curves = [d["rounds"] for job in jobs for d in job["demonstrations"]]
        for r in range(len(curves[0])):
            at = [c[r] for c in curves]

            def mean(key: str, at: list = at) -> str:
                values = [a[key] for a in at if a.get(key) is not None]
                return f"{sum(values) / len(values):.2f}" if values else "–"

            print(
                f"| {name} | {r} | {mean('cases')} | {mean('labels')} | {mean('corrections')} |"
                f" {mean('unaided_runs')} | {mean('label_agreement')} |"
                f" {mean('training_accuracy')} |"
            )
    print()
    print("| condition | repetitions | human commands | labels | corrections | driving (s) |"
          " policy driving (s) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for name, jobs in [*rows, *compared]:
        reps = [e for job in jobs for e in job["human_effort"]["repetitions"]]
        n = len(reps)

        def avg(key: str, reps: list = reps, n: int = n) -> str:
            return f"{sum(e.get(key, 0) for e in reps) / n:.1f}"

        print(
            f"| {name} | {n} | {avg('commands')} | {avg('labels')} | {avg('corrections')} |"
            f" {avg('learning_drive_s')} | {avg('autonomous_drive_s')} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
