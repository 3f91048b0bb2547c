"""``lfd-track evolve``: the paper's GA on a demonstration (a ``.lfdemo`` file, or a Minari dataset
written by ``lfd-track export minari``); writes the controller, its fitness curve and the
curve's numbers, all or none."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from ..dataset.reader import load_for_learning
from ..errors import LfdTrackError
from ..learning.fitness import training_accuracy
from ..learning.ga import GAConfig, evolve
from ..policy.controller import Controller
from ..policy.features import DEFAULT_FEATURES, FEATURE_SETS
from ..policy.map_geometry import MapGeometry
from ..policy.memory import MemoryConfig
from ..utils.outputs import shown_path
from ..vision.road_library import RoadLibrary
from .outputs import advance, check_output
from .types import EXIT_OK
from .types import non_negative_int as _seed
from .types import positive_int as _positive_int


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``evolve`` to the ``lfd-track`` commands."""
    evo = subparsers.add_parser(
        "evolve",
        help="evolve a controller from a demonstration",
        description="Run the paper's GA (Table 1) on a demonstration; writes the controller JSON and a fitness-curve PNG beside it (with its numbers as CSV).",
    )
    evo.add_argument(
        "demo", nargs="?", default=None, help="demonstration file (.lfdemo); or use --minari"
    )
    evo.add_argument(
        "--minari",
        metavar="DATASET_ID",
        default=None,
        help="learn from a Minari dataset written by lfd-track export minari instead",
    )
    evo.add_argument(
        "--datasets-path",
        default=None,
        help="Minari datasets folder for --minari (default: Minari's own)",
    )
    evo.add_argument("--seed", type=_seed, default=0, help="GA seed (default: 0)")
    evo.add_argument(
        "--generations",
        type=_positive_int,
        default=200,
        help="generations (default: 200, as in the paper)",
    )
    evo.add_argument(
        "--elitism",
        type=int,
        default=0,
        help="copies of the best kept each generation (default: 0, as in the paper)",
    )
    evo.add_argument(
        "--features",
        choices=FEATURE_SETS,
        default=DEFAULT_FEATURES,
        help="per-region inputs of the network: road_values (the paper's 40),"
        " road_values+colour (also each region's mean hue and saturation, from the recorded"
        " histograms: 160), near_felt (where the felt lies across the picture's nearest rows,"
        " and how much: 2) or none (the recorded memory inputs alone)",
    )
    evo.add_argument("--out", required=True, help="controller file to write (.json)")
    evo.set_defaults(func=run)
    return evo


def run(args: argparse.Namespace) -> int:
    """The ``evolve`` command."""
    from ..viz import plot_data

    if (args.demo is None) == (args.minari is None):
        raise LfdTrackError("give a demonstration file or --minari DATASET_ID (one of them)")
    png = Path(args.out).with_suffix(".fitness.png")
    for out in (args.out, png, plot_data.data_path(png)):
        check_output(out, [("demonstration", args.demo)])
    if args.minari is not None:
        from ..dataset.minari import cases_from_minari

        if args.features != DEFAULT_FEATURES:
            raise LfdTrackError(
                f"--features {args.features} needs a .lfdemo file (a Minari dataset holds the"
                " road values only)"
            )

        cases = cases_from_minari(args.minari, datasets_path=args.datasets_path)
        return _learn(
            args,
            png,
            inputs=cases.inputs,
            commands=cases.actions,
            library=cases.library,
            memory=cases.memory,
            title=f"Minari dataset {args.minari}",
            note="",
        )
    demo, library, memory = load_for_learning(args.demo)
    if args.features == "none" and memory is None:
        raise LfdTrackError(
            f"{shown_path(args.demo)}: --features none reads the memory inputs alone, and this"
            " recording has none (record it with --memory)"
        )
    return _learn(
        args,
        png,
        inputs=demo.policy_inputs(args.features),
        commands=demo.commands,
        library=library,
        memory=memory,
        title=shown_path(Path(args.demo).name),
        note="" if demo.metadata["complete"] else " (an interrupted recording)",
        frame_size=_recorded_frame_size(demo.metadata),
        map_geometry=_recorded_map_geometry(demo.metadata),
    )


def _recorded_frame_size(metadata: dict[str, Any]) -> tuple[int, int]:
    """(width, height) of the frames a recording was made with: its preset's camera for a
    simulated one whose preset still loads, else the paper's 640 x 480."""
    from ..core.frame import FRAME_HEIGHT, FRAME_WIDTH
    from ..envs.presets import load_preset

    preset = metadata.get("preset")
    if metadata.get("kind") == "simulated" and isinstance(preset, str):
        try:
            camera = load_preset(preset).camera
        except (OSError, ValueError, LfdTrackError):
            return FRAME_WIDTH, FRAME_HEIGHT
        return camera.frame_width_px, camera.frame_height_px
    return FRAME_WIDTH, FRAME_HEIGHT


def _recorded_map_geometry(metadata: dict[str, Any]) -> MapGeometry:
    """The map geometry a recording's ``fresh_felt`` inputs were computed with: the one it
    records (a robot's profile, ``--profile``), else its preset's world for a simulated one
    whose preset still loads, else the robot's (the paper preset's camera and rates at the
    recording's control period, if it names one)."""
    from ..envs.presets import load_preset
    from ..policy.map_geometry import hardware_geometry

    if "map_geometry" in metadata:
        try:
            return MapGeometry.from_dict(metadata["map_geometry"])
        except ValueError as exc:
            raise LfdTrackError(f"the recording's map geometry: {exc}") from None
    preset = metadata.get("preset")
    if metadata.get("kind") == "simulated" and isinstance(preset, str):
        try:
            return MapGeometry.from_preset(load_preset(preset))
        except (OSError, ValueError, LfdTrackError):
            pass
    period = metadata.get("control_period_s")
    if isinstance(period, int | float) and not isinstance(period, bool) and period > 0:
        return hardware_geometry(period_s=float(period))
    return hardware_geometry()


def _learn(
    args: argparse.Namespace,
    png: Path,
    *,
    inputs: np.ndarray,
    commands: np.ndarray,
    library: RoadLibrary,
    memory: MemoryConfig | None,
    title: str,
    note: str,
    frame_size: tuple[int, int] = (640, 480),
    map_geometry: MapGeometry | None = None,
) -> int:
    """Evolve on the cases, then write the controller and its fitness curve."""
    # Lazy: the drawing and progress-bar stack (OpenCV, tqdm) loads only when the command runs.
    from ..utils.progress import progress_bar
    from ..viz import plot_data, plots

    config = GAConfig(generations=args.generations, elitism=args.elitism)
    with progress_bar(
        config.generations, "evolving", unit=" generations", enabled=not args.quiet
    ) as bar:
        result = evolve(
            inputs,
            commands,
            config,
            np.random.default_rng(args.seed),
            progress=lambda g, best, mean: advance(bar, g, f"best fitness {best:.4f}"),
        )
    controller = Controller.from_evolution(
        library,
        result,
        seed=args.seed,
        memory=memory,
        features=args.features,
        frame_size=frame_size,
        map_geometry=map_geometry,
    )
    accuracy = training_accuracy(result.best_weights, inputs, commands)
    curves = [
        ("best", result.best_history, (200, 30, 30)),
        ("mean", result.mean_history, (30, 80, 200)),
    ]
    picture = plots.fitness_plot(
        curves,
        title=f"Fitness of each generation: {title}, GA seed {args.seed}",
        notes=plots.fitness_notes(config.elitism),
    )
    # All three files or none: each is written under a hidden name beside its own first, and
    # they are moved into place together (the controller last), so a failure leaves the
    # earlier ones as they were.
    staged = plot_data.StagedFiles()
    try:
        plot_data.stage_picture(png, picture, plot_data.fitness_table(curves), staged)
        controller.save(staged.add(args.out))
        staged.publish()
    finally:
        staged.discard()
    print(
        f"{shown_path(args.out)}: best fitness {result.best_fitness:.4f} (generation "
        f"{result.best_generation}), training accuracy {accuracy:.1%} on {len(commands)} cases"
        f"{note}; fitness curve {shown_path(png)} (numbers {shown_path(plot_data.data_path(png))})"
    )
    return EXIT_OK
