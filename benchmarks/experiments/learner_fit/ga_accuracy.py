"""Training accuracy of the paper-configured GA on simulator demonstrations, over several seeds.

For each seed s: record one demonstration on the training track with the scripted human
(privileged driver, ``run_demonstration(seed=s)``), load it, evolve with ``GAConfig()`` (Table 1)
and ``np.random.default_rng(s)``, and score the best network on its own training cases: accuracy
is the fraction of cases whose largest output is the demonstrated command (an exact tie counts as
wrong). The same is repeated with ``GAConfig(elitism=2)`` (an option, off by default) for
comparison.

Besides accuracy and fitness, each row carries what is needed to tell a stall from a slow climb:
the best fitness after 1, 10, 50, 100 and 200 generations (and 500, 1000 for the optional long
run), the classes the network predicts, the share of training outputs whose winning margin
reaches the fitness threshold, and two references on the same cases that say how much the road
values carry: a class-balanced least-squares linear classifier (40 inputs + bias) and the
majority class.

Run: ``.venv/bin/python benchmarks/experiments/learner_fit/ga_accuracy.py [--seeds 10] [--long-generations 1000]`` —
prints markdown tables and writes ``benchmarks/experiments/learner_fit/results/ga_accuracy.json``.
"""

from __future__ import annotations

import argparse
import json
import platform
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from lfd_track.core.commands import Command
from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import run_demonstration
from lfd_track.learning.fitness import imitation_fitness
from lfd_track.learning.ga import GAConfig, evolve
from lfd_track.policy.mlp import mlp_forward

RESULTS = Path(__file__).resolve().parent / "results" / "ga_accuracy.json"
CLASSES = [c.name.lower() for c in Command]  # forward, left, right
CHECKPOINTS = (1, 10, 50, 100, 200, 500, 1000)
VARIANTS = {"paper": GAConfig(), "elitism2": GAConfig(elitism=2)}


def recalls(predicted: np.ndarray, actual: np.ndarray) -> dict[str, float | None]:
    """Per-class recall (share of a class's cases predicted as that class); None if no cases."""
    out: dict[str, float | None] = {}
    for c, name in enumerate(CLASSES):
        mask = actual == c
        out[name] = float((predicted[mask] == c).mean()) if mask.any() else None
    return out


def argmax_no_tie(outputs: np.ndarray) -> np.ndarray:
    """Index of the largest output per row, -1 where the largest value is shared; (N, 3) → (N,)."""
    best = outputs.argmax(axis=1)
    top = outputs[np.arange(outputs.shape[0]), best]
    tied = (outputs == top[:, None]).sum(axis=1) > 1
    return np.where(tied, -1, best)


def linear_reference(inputs: np.ndarray, actions: np.ndarray) -> dict[str, Any]:
    """Class-balanced least-squares one-vs-rest linear classifier, scored on its training cases.

    Not part of the method: it only says how separable the road values are at all.
    """
    x = np.hstack([inputs, np.ones((inputs.shape[0], 1))])
    counts = np.bincount(actions, minlength=3)
    weight = np.sqrt(1.0 / counts[actions])  # each class weighs the same, as in Algorithm 3
    targets = np.eye(3)[actions]
    coef, *_ = np.linalg.lstsq(x * weight[:, None], targets * weight[:, None], rcond=None)
    predicted = (x @ coef).argmax(axis=1)
    return {
        "accuracy": float((predicted == actions).mean()),
        "recall": recalls(predicted, actions),
    }


def score_run(result, inputs: np.ndarray, actions: np.ndarray, threshold: float) -> dict[str, Any]:
    """Accuracy, per-class recall, predicted classes and output margins of the best network."""
    outputs = mlp_forward(result.best_weights, inputs)  # (N, 3)
    predicted = argmax_no_tie(outputs)
    others = np.array([[1, 2], [0, 2], [0, 1]])[actions]
    margin = outputs[np.arange(len(actions)), actions][:, None] - np.take_along_axis(
        outputs, others, axis=1
    )
    predicted_counts = {name: int((predicted == c).sum()) for c, name in enumerate(CLASSES)}
    n_predicted_classes = sum(1 for v in predicted_counts.values() if v > 0)
    fitness_check = float(
        imitation_fitness(result.best_weights[None], inputs, actions, threshold)[0]
    )
    return {
        "best_fitness": result.best_fitness,
        "fitness_recomputed": fitness_check,
        "best_generation": result.best_generation,
        "best_at_generation": {
            str(g): float(result.best_history[:g].min())
            for g in CHECKPOINTS
            if g <= len(result.best_history)
        },
        "accuracy": float((predicted == actions).mean()),
        "recall": recalls(predicted, actions),
        "predicted_counts": predicted_counts,
        "ties": int((predicted == -1).sum()),
        "degenerate": n_predicted_classes <= 1,
        "margin_at_threshold": float((margin >= threshold).mean()),
        "mean_output_by_class": {
            name: outputs[actions == c].mean(axis=0).round(4).tolist()
            for c, name in enumerate(CLASSES)
            if (actions == c).any()
        },
    }


def input_statistics(inputs: np.ndarray, actions: np.ndarray) -> dict[str, float]:
    """How much the road values vary: overall level, spread across cases, class-mean gaps."""
    class_means = np.array([inputs[actions == c].mean(axis=0) for c in range(3)])
    return {
        "mean": float(inputs.mean()),
        "min": float(inputs.min()),
        "max": float(inputs.max()),
        "mean_std_across_cases": float(inputs.std(axis=0).mean()),
        "max_class_mean_gap": float(np.abs(class_means[:, None] - class_means[None]).max()),
        "mean_class_mean_gap": float(
            np.mean(
                [
                    np.abs(class_means[a] - class_means[b]).mean()
                    for a, b in ((0, 1), (0, 2), (1, 2))
                ]
            )
        ),
    }


def run_seed(seed: int, work_dir: Path, variants: dict[str, GAConfig]) -> dict[str, Any]:
    """Record, load, evolve with every variant and score one seed."""
    path = work_dir / f"demo_{seed:02d}.lfdemo"
    t0 = time.perf_counter()
    run_demonstration(path, seed=seed, fsync=False, overwrite=True)
    demo = load_demonstration(path)
    record_s = time.perf_counter() - t0
    inputs = np.asarray(demo.road_values, dtype=np.float64)
    actions = np.asarray(demo.commands, dtype=np.intp)
    row: dict[str, Any] = {
        "seed": seed,
        "cases": int(actions.size),
        "counts": {name: int((actions == c).sum()) for c, name in enumerate(CLASSES)},
        "record_s": record_s,
        "inputs": input_statistics(inputs, actions),
        "majority_accuracy": float(np.bincount(actions, minlength=3).max() / actions.size),
        "linear_reference": linear_reference(inputs, actions),
    }
    for name, config in variants.items():
        t0 = time.perf_counter()
        result = evolve(inputs, actions, config, np.random.default_rng(seed))
        row[name] = score_run(result, inputs, actions, config.threshold)
        row[name]["evolve_s"] = time.perf_counter() - t0
    return row


def summarise(rows: list[dict[str, Any]], variant: str) -> dict[str, Any]:
    """Mean / min / max over seeds of accuracy, fitness and per-class recall."""

    def stats(values: list[float]) -> dict[str, float]:
        a = np.asarray(values, dtype=np.float64)
        return {"mean": float(a.mean()), "min": float(a.min()), "max": float(a.max())}

    return {
        "accuracy": stats([r[variant]["accuracy"] for r in rows]),
        "best_fitness": stats([r[variant]["best_fitness"] for r in rows]),
        "recall": {
            name: stats(
                [r[variant]["recall"][name] for r in rows if r[variant]["recall"][name] is not None]
            )
            for name in CLASSES
        },
        "degenerate_runs": sum(r[variant]["degenerate"] for r in rows),
        "margin_at_threshold": stats([r[variant]["margin_at_threshold"] for r in rows]),
    }


def markdown(
    rows: list[dict[str, Any]], summary: dict[str, Any], variants: dict[str, GAConfig]
) -> str:
    """The per-seed tables and the summary as markdown."""
    lines = []
    for variant, config in variants.items():
        lines += [
            f"### {variant} ({config})",
            "",
            "| seed | cases | F/L/R | best fitness | gen | acc | recall F/L/R | predicted F/L/R"
            " | degenerate | best fitness by generation 1/10/50/100/200/... |",
            "|---:|---:|---|---:|---:|---:|---|---|---|---|",
        ]
        for r in rows:
            v = r[variant]
            counts = "/".join(str(r["counts"][c]) for c in CLASSES)
            rec = "/".join(
                "-" if v["recall"][c] is None else f"{v['recall'][c]:.2f}" for c in CLASSES
            )
            pred = "/".join(str(v["predicted_counts"][c]) for c in CLASSES)
            hist = "/".join(f"{x:.3f}" for x in v["best_at_generation"].values())
            lines.append(
                f"| {r['seed']} | {r['cases']} | {counts} | {v['best_fitness']:.4f} |"
                f" {v['best_generation']} | {v['accuracy']:.3f} | {rec} | {pred} |"
                f" {'yes' if v['degenerate'] else 'no'} | {hist} |"
            )
        s = summary[variant]
        lines += [
            "",
            f"accuracy mean {s['accuracy']['mean']:.3f} (min {s['accuracy']['min']:.3f},"
            f" max {s['accuracy']['max']:.3f}); best fitness mean {s['best_fitness']['mean']:.4f}"
            f" (min {s['best_fitness']['min']:.4f}, max {s['best_fitness']['max']:.4f});"
            " recall "
            + ", ".join(
                f"{c} {rc['mean']:.3f} [{rc['min']:.2f}..{rc['max']:.2f}]"
                for c, rc in ((c, s["recall"][c]) for c in CLASSES)
            )
            + f"; degenerate runs {s['degenerate_runs']}/{len(rows)}",
            "",
        ]
    lines += [
        "### references on the same cases",
        "",
        "| seed | majority acc | linear acc | linear recall F/L/R | mean road value | mean std"
        " | mean class-mean gap |",
        "|---:|---:|---:|---|---:|---:|---:|",
    ]
    for r in rows:
        lin = r["linear_reference"]
        rec = "/".join(f"{lin['recall'][c]:.2f}" for c in CLASSES)
        i = r["inputs"]
        lines.append(
            f"| {r['seed']} | {r['majority_accuracy']:.3f} | {lin['accuracy']:.3f} | {rec} |"
            f" {i['mean']:.3f} | {i['mean_std_across_cases']:.3f} |"
            f" {i['mean_class_mean_gap']:.3f} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="seeds 0..N-1 (default 10)")
    parser.add_argument("--keep", type=Path, default=None, help="keep demonstrations in this dir")
    parser.add_argument("--out", type=Path, default=RESULTS, help="result JSON path")
    parser.add_argument(
        "--long-generations",
        type=int,
        default=0,
        help="also run the paper GA for this many generations (a diagnostic, off by default)",
    )
    args = parser.parse_args()
    variants = dict(VARIANTS)
    if args.long_generations:
        variants[f"paper_{args.long_generations}gen"] = GAConfig(generations=args.long_generations)

    with tempfile.TemporaryDirectory() as tmp:
        work_dir = args.keep if args.keep is not None else Path(tmp)
        work_dir.mkdir(parents=True, exist_ok=True)
        rows = []
        for seed in range(args.seeds):
            rows.append(run_seed(seed, work_dir, variants))
            r = rows[-1]
            print(
                f"seed {seed}: {r['cases']} cases {r['counts']}, paper acc"
                f" {r['paper']['accuracy']:.3f} fit {r['paper']['best_fitness']:.4f}, elitism2 acc"
                f" {r['elitism2']['accuracy']:.3f} fit {r['elitism2']['best_fitness']:.4f}",
                flush=True,
            )
    summary = {variant: summarise(rows, variant) for variant in variants}
    print()
    print(markdown(rows, summary, variants))
    result = {
        "benchmark": "ga_training_accuracy",
        "demonstration": "run_demonstration(seed=s) on the training track, paper preset",
        "ga_seed": "np.random.default_rng(s)",
        "variants": {name: config.to_dict() for name, config in variants.items()},
        "machine": {"python": platform.python_version(), "numpy": np.__version__},
        "summary": summary,
        "rows": rows,
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
