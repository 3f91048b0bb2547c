"""Why the ceiling study's controllers still fail corner 4: how well its cases can be told apart.

The ceiling study (``benchmarks/experiments/ceiling/ceiling_testing_demo.toml``) teaches HG-DAgger with the
last-bend memory on the testing loop cut open, so corner 4 is in its demonstrations, and yet
corner 4 fails as often as when it is not. This relearns the study's repetitions (same seeds,
same code path as the runner: :func:`lfd_track.benchmark.runner.learn_repetition`), keeps every
case the learner saw (the demonstration and each round's interventions, with the pose each was
recorded at), and asks of the cases recorded near each corner of the loop:

- ``turning``: the share of them that are pivots (left or right), not forward;
- ``accuracy``: the share the learned network itself gets right (its largest output is the
  human's command), i.e. how well it fits them;
- ``neighbours disagree``: for each case, its 5 nearest cases in the network's input space (road
  values and memory input, Euclidean) among every case of the same repetition; the share of those
  neighbours whose command differs from its own. A high share means the inputs there do not
  separate the human's choices: similar views were answered differently.

"Near a corner" is within ``--radius`` (0.4 m) of its vertex; "straights" is every case farther
than that from all four corners and from the track's two ends (the turn-arounds).

Run: ``.venv/bin/python benchmarks/experiments/ceiling/ceiling_aliasing.py [--seed 0] [--repetitions 10]
[--workers 2]`` — writes ``benchmarks/experiments/ceiling/results/ceiling_aliasing.json`` and ``.md``.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from lfd_track.benchmark.runner import learn_repetition, repetition_seeds, repetition_streams
from lfd_track.dataset import load_demonstration
from lfd_track.policy.mlp import mlp_forward
from lfd_track.study.spec import load_study
from lfd_track.world.track import load_track

HERE = Path(__file__).resolve().parent
STUDY = HERE / "ceiling_testing_demo.toml"
CONDITION = "hg-dagger+memory.testing-demo"
RESULTS = HERE / "results"
NEIGHBOURS = 5


def _cases(rep_dir: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(inputs, commands, (x, y) positions) of every case the learner saw, demonstration first."""
    files = [rep_dir / "demonstration.lfdemo", *sorted(rep_dir.glob("interventions_r*.lfdemo"))]
    demos = [load_demonstration(f) for f in files]
    inputs = np.concatenate([d.inputs for d in demos])
    commands = np.concatenate([np.asarray(d.commands, dtype=np.intp) for d in demos])
    positions = np.concatenate([np.asarray(d.poses, dtype=np.float64)[:, :2] for d in demos])
    return inputs, commands, positions


def _neighbour_disagreement(inputs: np.ndarray, commands: np.ndarray) -> np.ndarray:
    """Per case: share of its NEIGHBOURS nearest other cases whose command differs."""
    squared = (inputs * inputs).sum(axis=1)
    distances = squared[:, None] + squared[None, :] - 2.0 * inputs @ inputs.T
    np.fill_diagonal(distances, np.inf)
    nearest = np.argpartition(distances, NEIGHBOURS, axis=1)[:, :NEIGHBOURS]
    return (commands[nearest] != commands[:, None]).mean(axis=1)


def analyse_repetition(args: tuple[int, int, float]) -> dict[str, Any]:
    """Relearn repetition ``index`` of benchmark ``seed``; per-region statistics of its cases."""
    import cv2

    cv2.setNumThreads(1)
    seed, index, radius = args
    (condition,) = [c for c in load_study(STUDY).conditions if c.name == CONDITION]
    config = condition.config
    demo_seed, ga_seed, _ = repetition_streams(repetition_seeds(seed, index + 1)[index])
    track = load_track(config.demo_track)
    with tempfile.TemporaryDirectory() as tmp:
        learned = learn_repetition(config, Path(tmp), demo_seed=demo_seed, ga_seed=ga_seed)
        inputs, commands, positions = _cases(Path(tmp))
    weights = learned.controller.weights
    predicted = mlp_forward(weights, inputs).argmax(axis=1)
    disagree = _neighbour_disagreement(inputs, commands)
    corners = {c.label: np.asarray(track.vertices[c.vertex]) for c in track.corners}
    ends = [np.asarray(track.vertices[0]), np.asarray(track.vertices[-1])]

    def distance_to(point: np.ndarray) -> np.ndarray:
        return np.hypot(*(positions - point).T)

    regions = {f"corner {label}": distance_to(p) <= radius for label, p in corners.items()}
    near_any = np.zeros(len(commands), dtype=bool)
    for point in [*corners.values(), *ends]:
        near_any |= distance_to(point) <= radius
    regions["straights"] = ~near_any
    regions["all"] = np.ones(len(commands), dtype=bool)
    out: dict[str, Any] = {"repetition": index, "cases": len(commands), "regions": {}}
    for name, mask in regions.items():
        out["regions"][name] = {
            "cases": int(mask.sum()),
            "turning": int((commands[mask] != 0).sum()),
            "correct": int((predicted[mask] == commands[mask]).sum()),
            "neighbours_disagree_sum": float(disagree[mask].sum()),
        }
    return out


def _table(summary: dict[str, Any]) -> str:
    lines = [
        f"Ceiling study, `{CONDITION}`, seed {summary['seed']}, {summary['repetitions']} "
        f"repetitions relearned (`benchmarks/experiments/ceiling/ceiling_aliasing.py`); cases within "
        f"{summary['radius_m']} m of each corner, and on the straights. Pooled over repetitions.",
        "",
        "| region | cases | turning | network right | neighbours disagree |",
        "|---|---|---|---|---|",
    ]
    for name, r in summary["regions"].items():
        n = max(r["cases"], 1)
        lines.append(
            f"| {name} | {r['cases']} | {100 * r['turning'] / n:.0f} % | "
            f"{100 * r['correct'] / n:.0f} % | {100 * r['neighbours_disagree_sum'] / n:.0f} % |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repetitions", type=int, default=10)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--radius", type=float, default=0.4, help="[m] 'near a corner'")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    jobs = [(args.seed, i, args.radius) for i in range(args.repetitions)]
    with ProcessPoolExecutor(args.workers) as pool:
        reps = list(pool.map(analyse_repetition, jobs))
    regions: dict[str, dict[str, float]] = {}
    for rep in reps:
        for name, r in rep["regions"].items():
            total = regions.setdefault(name, dict.fromkeys(r, 0))
            for key, value in r.items():
                total[key] += value
    summary = {
        "study": str(STUDY.relative_to(HERE.parents[2])),
        "condition": CONDITION,
        "seed": args.seed,
        "repetitions": args.repetitions,
        "radius_m": args.radius,
        "neighbours": NEIGHBOURS,
        "regions": regions,
        "per_repetition": reps,
        "wall_s": round(time.perf_counter() - start, 1),
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "ceiling_aliasing.json").write_text(json.dumps(summary, indent=2) + "\n")
    text = _table(summary)
    (RESULTS / "ceiling_aliasing.md").write_text(text)
    print(text)
    print(f"{summary['wall_s']} s")
    return 0 if all(math.isfinite(r["cases"]) for r in regions.values()) else 1


if __name__ == "__main__":
    raise SystemExit(main())
