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
as the study key ``extra_cases`` (``lfd_track/learning/extra_cases.py``), whose functions this
script now calls to write and add the cases (the same files, the same order).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "sharp_corners"))

import oracle_learner  # noqa: E402

from lfd_track.learning.extra_cases import load_cases, save_cases, with_extra_cases  # noqa: E402
from lfd_track.methods import baseline  # noqa: E402

_own_cases = baseline.offline_cases


def collect_into(folder: Path) -> None:
    """From now on every offline demonstration's cases are also saved into ``folder``, one file
    per repetition, named by its demonstration seed (``save_cases``'s format)."""
    folder.mkdir(parents=True, exist_ok=True)

    def saving(context: Any) -> Any:
        made = _own_cases(context)
        save_cases(folder / f"{context.demo_seed:020d}", *made[-1])
        return made

    baseline.offline_cases = saving


def fit_with(folder: Path) -> None:
    """From now on every offline learner fits its own cases followed by those in ``folder``
    (what the product's ``extra_cases`` does)."""
    print(f"{len(load_cases(folder)[1])} cases added from {folder}")

    def pooled(context: Any) -> Any:
        summary, demo, library, views, cases = _own_cases(context)
        return summary, demo, library, views, with_extra_cases(folder, *cases)

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
