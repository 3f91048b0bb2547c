"""Round 41's candidate, a prototype: the room's demonstration fitted together with the human
model's demonstrations in ten other rooms.

Parts 52-53 of ``../../sharp_corners/README.md`` read that the teaching decides which rooms fall
under the every-room bar: taught again in the same room, from a new demonstration, three of the
six rooms under it reach it and three others fall under, and a new demonstration moves more of
them than new fits of the same cases. One demonstration of some 260 cases is what a repetition's
five networks are fitted on. This prototype gives the fits more of the same teacher: the cases
(with their mirror images) of the goal's demonstration in ten rooms of their own, drawn from the
``randomized`` ranges under seed 300 (no other study uses it), are added to each repetition's own
cases, every case weighing alike (the case weights by command over the pooled cases). The room's
own demonstration still gives its road library, its map and its own cases; the human in the room
gives as many commands as before. The ten rooms' demonstrations would ship with a product as
data, taught once by the same human model in simulation.

Two steps, each one process per seed (the jobs run in this process,
``../../sharp_corners/oracle_learner.py``'s ``run_in_process``):

    .venv/bin/python benchmarks/experiments/human_goal/round41/prior.py collect --cases benchmarks/experiments/human_goal/round41/results/prior_cases --seed 300 --study benchmarks/experiments/human_goal/round41/prior_rooms.toml --out benchmarks/experiments/human_goal/round41/results/prior_rooms
    .venv/bin/python benchmarks/experiments/human_goal/round41/prior.py fit --cases benchmarks/experiments/human_goal/round41/results/prior_cases --seed 100 --study benchmarks/experiments/human_goal/round41/prior.toml --out benchmarks/experiments/human_goal/round41/results/prior

``collect`` saves every repetition's cases (inputs and commands, mirror images included, as the
learner fits them) as one ``.npz`` per repetition; ``fit`` adds all of them, in the order of
their file names, after each repetition's own cases. The jobs' results record the study's
configuration, not the added cases; the study's name and description say what it adds. This is
the prototype the round and its test ran; the product's learners have since taken the added cases
as the study key ``extra_cases`` (``lfd_track/learning/extra_cases.py``), which reads the files
``collect`` writes and puts them after a repetition's own cases as ``fit`` does.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "sharp_corners"))

import oracle_learner  # noqa: E402

from lfd_track.methods import baseline  # noqa: E402

_own_cases = baseline.offline_cases


def collect_into(folder: Path) -> None:
    """From now on every offline demonstration's cases are also saved into ``folder``, one file
    per repetition, named by its demonstration seed."""
    folder.mkdir(parents=True, exist_ok=True)

    def saving(context: Any) -> Any:
        made = _own_cases(context)
        x, a = made[-1]
        np.savez(folder / f"{context.demo_seed:020d}.npz", x=x, a=np.asarray(a, dtype=np.int64))
        return made

    baseline.offline_cases = saving


def load_cases(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    """All the cases saved in ``folder`` (by :func:`collect_into`), in the order of the files'
    names; a folder without any, or with files of other widths, is refused in one line."""
    files = sorted(folder.glob("*.npz"))
    if not files:
        raise SystemExit(f"{folder}: no saved cases (*.npz)")
    xs, actions = [], []
    for f in files:
        with np.load(f) as data:
            xs.append(np.asarray(data["x"], dtype=np.float64))
            actions.append(np.asarray(data["a"], dtype=np.int64))
    if len({x.shape[1] for x in xs}) != 1:
        raise SystemExit(f"{folder}: the saved cases have different numbers of inputs")
    return np.concatenate(xs), np.concatenate(actions)


def fit_with(folder: Path) -> None:
    """From now on every offline learner fits its own cases followed by those in ``folder``."""
    prior_x, prior_a = load_cases(folder)
    print(f"{len(prior_a)} cases added from {folder}")

    def pooled(context: Any) -> Any:
        summary, demo, library, views, (x, a) = _own_cases(context)
        if x.shape[1] != prior_x.shape[1]:
            raise SystemExit(
                f"{folder}: the saved cases have {prior_x.shape[1]} inputs, the study's "
                f"{x.shape[1]}"
            )
        cases = (
            np.concatenate([x, prior_x]),
            np.concatenate([np.asarray(a, dtype=np.int64), prior_a]),
        )
        return summary, demo, library, views, cases

    baseline.offline_cases = pooled


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("step", choices=("collect", "fit"))
    parser.add_argument("--cases", required=True, help="the folder of saved cases")
    parser.add_argument("--study", required=True, help="the study file")
    parser.add_argument("--out", required=True, help="the study's output folder")
    parser.add_argument("--seed", type=int, help="run only this seed's jobs")
    args = parser.parse_args()
    if args.step == "collect":
        collect_into(Path(args.cases))
    else:
        fit_with(Path(args.cases))
    oracle_learner.run_in_process(args.study, args.out, args.seed, tables=True)


if __name__ == "__main__":
    main()
