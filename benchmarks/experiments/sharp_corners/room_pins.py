"""Part 56 of ``README.md``: which of a room's drawn settings keeps the goal's learner under the bar?

One repetition of a study (``--seed``, ``--repetition``) is taught and driven as the study runs it
(its demonstration, fits and trials streams, its room), once as drawn and once with each group of
the room's drawn settings pinned at the paper world's values, the rest as drawn: the colours, the
light, the white-balance cast, the exposure target, the noise, the vignetting, the camera mount,
the treads; and the whole paper world. A group whose pinning brings the room to the bar is one
the room's shortfall rests on. The groups are the ``randomized`` preset's ranges
(``envs/randomized.toml``), every one in exactly one group. Exploratory: one room; it points at
what a controlled experiment on other rooms should test.

    .venv/bin/python benchmarks/experiments/sharp_corners/room_pins.py --study benchmarks/experiments/sharp_corners/trials/goal41_validation.toml --seed 100 --repetition 4 --workers 2 --out benchmarks/experiments/sharp_corners/results/room_pins_100_4.md

The teaching's streams are the repetition's own (``runner.repetition_streams``), so the full room
is the study's own run of that repetition and must lap as it did (the table says so).
"""

from __future__ import annotations

import argparse
import dataclasses
import multiprocessing
import tempfile
from pathlib import Path
from typing import Any

from lfd_track.benchmark import runner
from lfd_track.envs.presets import Preset, load_preset
from lfd_track.study.spec import load_study

#: (label, the randomized preset's fields pinned at the paper's values), in the table's order.
GROUPS: list[tuple[str, tuple[str, ...]]] = [
    ("full room (nothing pinned)", ()),
    ("colours pinned", ("appearance.felt_rgb", "appearance.carpet_rgb")),
    (
        "light pinned",
        (
            "lighting.ambient",
            "lighting.pool_strength",
            "lighting.shadow_count",
            "lighting.shadow_darkness",
        ),
    ),
    ("white-balance cast pinned", ("sensor.white_balance_cast",)),
    ("exposure target pinned", ("sensor.exposure_target",)),
    ("noise pinned", ("sensor.noise_std",)),
    ("vignetting pinned", ("sensor.vignetting",)),
    ("camera mount pinned", ("camera.height_m", "camera.pitch_deg", "camera.vfov_deg")),
    ("treads pinned", ("rover.slip_noise_std", "rover.motor_asymmetry_std")),
]
ALL = tuple(name for _, fields in GROUPS for name in fields)
GROUPS.append(("every setting pinned (the paper world's values)", ALL))


def pinned(room: Preset, fields: tuple[str, ...]) -> Preset:
    """``room`` with each of ``fields`` ("section.field") at the paper preset's value."""
    paper = load_preset("paper")
    for name in fields:
        section, attr = name.split(".")
        value = getattr(getattr(paper, section), attr)
        part = dataclasses.replace(getattr(room, section), **{attr: value})
        room = dataclasses.replace(room, **{section: part})
    return room


def run_one(job: tuple[str, int, int, tuple[str, ...], str]) -> dict[str, Any]:
    """Teach and drive the repetition with ``fields`` pinned; its loop laps and training runs."""
    study_file, seed, repetition, fields, work = job
    study = load_study(study_file)
    config = dataclasses.replace(study.conditions[0].config, repetitions=study.repetitions)
    drawn = runner.repetition_preset

    def pinning(cfg: Any, rep_seed: int) -> Any:
        return pinned(drawn(cfg, rep_seed), fields)

    runner.repetition_preset = pinning  # type: ignore[assignment]
    rep_seed = runner.repetition_seeds(seed, study.repetitions)[repetition]
    result = runner.run_repetition(repetition, rep_seed, config, work)
    loops = [o for o in result.outcomes if o.track.startswith("random")]
    training = [o for o in result.outcomes if not o.track.startswith("random")]
    return {
        "loops": sum(o.success for o in loops),
        "n_loops": len(loops),
        "training": sum(o.success for o in training),
        "n_training": len(training),
        "commands": result.effort.get("commands"),
        "accuracy": result.training_accuracy,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", required=True, help="the study file (its first condition)")
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--repetition", type=int, required=True)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", required=True, help="the markdown table to write")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        jobs = [
            (args.study, args.seed, args.repetition, fields, str(Path(tmp) / f"g{k}"))
            for k, (_, fields) in enumerate(GROUPS)
        ]
        with multiprocessing.get_context("fork").Pool(args.workers) as pool:
            rows = pool.map(run_one, jobs, chunksize=1)
    lines = [
        f"# The goal's learner in room ({args.seed}, {args.repetition}) with parts of it pinned",
        "",
        f"`room_pins.py` on `{Path(args.study).name}`, seed {args.seed}, repetition"
        f" {args.repetition}: the repetition's own teaching streams and trials; each group of"
        " the room's drawn settings pinned at the paper world's values, the rest as drawn."
        " Exploratory: one room.",
        "",
        "| world | loop laps | training track | human commands | training accuracy |",
        "|---|---|---|---|---|",
    ]
    for (label, _), row in zip(GROUPS, rows, strict=True):
        lines.append(
            f"| {label} | {row['loops']}/{row['n_loops']} | {row['training']}/{row['n_training']}"
            f" | {row['commands']} | {row['accuracy']:.3f} |"
        )
    Path(args.out).write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
