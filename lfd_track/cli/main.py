"""The ``lfd-track`` command: demonstrate, evolve, drive, run the paper benchmark, and hardware.

User errors (bad files, unknown tracks, bad flags) print one line to stderr and exit 1 (2 for bad
usage); nothing already saved is overwritten by a half-written file (every output is written
atomically or, for demonstrations, crash-safely). An output only ever replaces a regular file:
one whose name is a symbolic link (wherever it points), a device, a FIFO or a socket is refused
before any work (see outputs.py). Names that are not valid UTF-8 are shown with \\x escapes (in
messages and on plots); a track or preset name that a recording or a benchmark would record
must be UTF-8 and is otherwise refused before any work.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

from .atomic import replace_file
from .cli_types import non_negative_int as _seed
from .cli_types import positive_int as _positive_int
from .errors import LfdTrackError
from .outputs import (
    in_progress_name,
    keep_partial,
    refuse_undecodable,
    refuse_unsafe_output,
    shown_path,
    taken,
)
from .signals import (
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    Terminated,
    interrupted_exit_code,
    raise_terminated,
)

EXIT_OK, EXIT_ERROR, EXIT_USAGE = 0, 1, 2
EXIT_CODES = (EXIT_OK, EXIT_ERROR, EXIT_USAGE, EXIT_INTERRUPTED, EXIT_TERMINATED)
"""Every exit code of the commands (130, 143: stopped by Ctrl-C, SIGTERM; see signals.py)."""


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see --help)\n")


def _cores() -> int:
    """CPU cores this process may use (the default number of benchmark workers)."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _advance(bar: Any, done: float, note: str = "") -> None:
    """Move a progress bar to ``done`` (it may go back) with a short note."""
    if note:
        bar.set_postfix_str(note, refresh=False)
    bar.update(done - bar.n)


# --------------------------------------------------------------------------------- demo
def _same_file(a: str | Path, b: str | Path) -> bool:
    """Whether ``a`` and ``b`` name the same file (through links, ``..``, symbolic links)."""
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist
        return os.path.realpath(a) == os.path.realpath(b)


def _check_output(out: str | Path, inputs: Sequence[tuple[str, str | Path | None]]) -> None:
    """Refuse, before any work, an output that is one of the ``(what, path)`` inputs (it would be
    replaced by the output), exists and is not a regular file (a folder, device, FIFO, socket or
    symbolic link), or is below something that is not a folder."""
    out = Path(out)
    for what, path in inputs:
        if path is not None and Path(path).is_file() and _same_file(out, path):
            raise LfdTrackError(
                f"{shown_path(out)}: is the {what} this command reads; write to another file"
            )
    refuse_unsafe_output(out)
    if out.is_dir():
        raise LfdTrackError(f"{shown_path(out)}: is a folder, expected a file name")
    for parent in out.parents:
        if parent.exists():
            if not parent.is_dir():
                raise LfdTrackError(f"{shown_path(out)}: {shown_path(parent)} is not a folder")
            break


def _temporary_beside(out: Path) -> Path:
    """A new empty hidden file beside ``out`` (its folder made if missing): an output is written
    there first and moved over ``out`` once the command's other output is written too."""
    from .atomic import temporary_prefix

    out.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=temporary_prefix(out), suffix=".tmp", dir=out.parent)
    os.close(fd)
    return Path(name)


def _cmd_demo(args: argparse.Namespace) -> int:
    from .demo.dataset import load_demonstration
    from .demo.demonstrator import HumanConfig, run_demonstration
    from .progress import progress_bar

    out = Path(args.out)
    _check_output(out, [("track", args.track), ("preset", args.preset)])
    for what, name in (("track", args.track), ("preset", args.preset)):
        refuse_undecodable(name, what)  # recorded in the file's metadata
    if taken(out) and not args.force:
        raise LfdTrackError(
            f"{shown_path(out)}: already exists; an earlier recording is never replaced"
            " (use --force to replace it)"
        )
    human = HumanConfig(careful=not args.careless)
    # Without --force the recording goes straight to its name: interrupted, it is still there,
    # visible and usable. With --force an existing file is kept until the new one is complete:
    # the new one is written under a name of its own and, interrupted, kept under a free
    # partial name (never over a partial recording kept earlier).
    target = in_progress_name(out) if out.exists() else out
    commands = 0

    def progress(n: int) -> None:
        nonlocal commands
        commands = n
        bar.update(n - bar.n)

    previous = signal.signal(signal.SIGTERM, raise_terminated)
    try:
        # A running count: how many commands the protocol takes is known only when it ends.
        with progress_bar(None, "demonstrating", unit=" commands", enabled=not args.quiet) as bar:
            summary = run_demonstration(
                target,
                seed=args.seed,
                track=args.track,
                preset=args.preset,
                human=human,
                overwrite=args.force and target == out,
                progress=progress,
            )
    except (KeyboardInterrupt, Terminated) as exc:
        code = interrupted_exit_code(exc)
        if not target.exists():
            print("lfd-track demo: interrupted before anything was recorded", file=sys.stderr)
            return code
        kept_at = target if target == out else keep_partial(target, out)
        try:
            kept = f"{load_demonstration(kept_at).n_cases} cases"
        except LfdTrackError:
            kept = "no usable cases"
        print(
            f"lfd-track demo: interrupted after {commands} commands; the partial recording"
            f" ({kept}) is kept at {shown_path(kept_at)} (lfd-track evolve can train on it)",
            file=sys.stderr,
        )
        return code
    except BaseException:
        if target != out:  # the unfinished replacement; the earlier recording is untouched
            target.unlink(missing_ok=True)
        raise
    finally:
        signal.signal(signal.SIGTERM, previous)
    if target != out:
        try:
            replace_file(target, out)
        except LfdTrackError as exc:  # ``out`` became a link, device, ... meanwhile
            kept = keep_partial(target, out)
            raise LfdTrackError(f"{exc}; the new recording is kept at {shown_path(kept)}") from None
    print(
        f"{shown_path(out)}: {summary.n_cases} cases ({summary.counts['forward']} forward, "
        f"{summary.counts['left']} left, {summary.counts['right']} right), "
        f"turn-arounds {', '.join(summary.turnarounds)}, library {summary.library_models} models "
        f"in {summary.library_types} types"
    )
    return EXIT_OK


# --------------------------------------------------------------------------------- evolve
def _cmd_evolve(args: argparse.Namespace) -> int:
    import numpy as np

    from .controller import Controller
    from .demo.dataset import load_demonstration
    from .learning.fitness import training_accuracy
    from .learning.ga import GAConfig, evolve
    from .plots import fitness_notes, fitness_plot, write_png
    from .progress import progress_bar
    from .vision.road_library import RoadLibrary

    png = Path(args.out).with_suffix(".fitness.png")
    for out in (args.out, png):
        _check_output(out, [("demonstration", args.demo)])
    demo = load_demonstration(args.demo)
    if demo.n_cases == 0:
        raise LfdTrackError(f"{shown_path(args.demo)}: the demonstration holds no cases")
    library_dict = demo.metadata.get("road_library")
    if not isinstance(library_dict, dict):
        raise LfdTrackError(
            f"{shown_path(args.demo)}: no road library stored (an interrupted recording without a"
            " library log, written by an older lfd-track: record it again)"
        )
    try:
        library = RoadLibrary.from_dict(library_dict)
    except (ValueError, KeyError, TypeError) as exc:
        raise LfdTrackError(f"{shown_path(args.demo)}: bad road library ({exc})") from None
    if library.n_models == 0:
        raise LfdTrackError(
            f"{shown_path(args.demo)}: its road library is empty (no frame was learned while"
            " recording), so a controller could not see the road"
        )
    try:
        memory = demo.memory_settings()
    except ValueError as exc:
        raise LfdTrackError(f"{shown_path(args.demo)}: {exc}") from None
    config = GAConfig(generations=args.generations, elitism=args.elitism)
    with progress_bar(
        config.generations, "evolving", unit=" generations", enabled=not args.quiet
    ) as bar:
        result = evolve(
            demo.inputs,
            demo.commands,
            config,
            np.random.default_rng(args.seed),
            progress=lambda g, best, mean: _advance(bar, g, f"best fitness {best:.4f}"),
        )
    controller = Controller.from_evolution(library, result, seed=args.seed, memory=memory)
    accuracy = training_accuracy(result.best_weights, demo.inputs, demo.commands)
    picture = fitness_plot(
        [
            ("best", result.best_history, (200, 30, 30)),
            ("mean", result.mean_history, (30, 80, 200)),
        ],
        title=f"Fitness of each generation: {shown_path(Path(args.demo).name)},"
        f" GA seed {args.seed}",
        notes=fitness_notes(config.elitism),
    )
    # Both files or neither: the controller waits under a hidden name beside --out until the
    # fitness curve is written, so a failure leaves an earlier pair as it was.
    staged = _temporary_beside(Path(args.out))
    try:
        controller.save(staged)
        write_png(str(png), picture)
        replace_file(staged, args.out)
    except BaseException:
        staged.unlink(missing_ok=True)
        raise
    partial = "" if demo.metadata["complete"] else " (an interrupted recording)"
    print(
        f"{shown_path(args.out)}: best fitness {result.best_fitness:.4f} (generation "
        f"{result.best_generation}), training accuracy {accuracy:.1%} on {demo.n_cases} cases"
        f"{partial}; fitness curve {shown_path(png)}"
    )
    return EXIT_OK


# --------------------------------------------------------------------------------- drive
def _lap_line(lap: dict[str, Any]) -> str:
    if lap["success"]:
        outcome = "success"
    elif lap["failed_corner"] is None:
        outcome = f"{lap['failure']} after the last corner"
    else:
        outcome = f"{lap['failure']} at corner {lap['failed_corner']}"
    negotiated = " ".join(lap["corners_negotiated"]) or "-"
    return f"  lap {lap['lap']}: {outcome}; negotiated {negotiated} ({lap['steps']} steps)"


def _cmd_drive(args: argparse.Namespace) -> int:
    import numpy as np

    from .benchmark.runner import run_trial
    from .controller import Controller
    from .env import LfDTrackEnv
    from .plots import TrackRun, laps_plot, write_png
    from .progress import progress_bar
    from .video import DriveVideo

    controller = Controller.load(args.controller)
    controller.learn = controller.learn or args.keep_learning
    inputs = [("controller", args.controller), ("track", args.track), ("preset", args.preset)]
    for out in (args.video, args.plot):
        if out:
            _check_output(out, inputs)
    if args.video and args.plot and _same_file(args.video, args.plot):
        raise LfdTrackError(f"{shown_path(args.plot)}: given as both --video and --plot")
    env = LfDTrackEnv(track=args.track, reverse=args.reverse, preset=args.preset)
    laps: list[dict[str, Any]] = []
    trajectories = []
    video = DriveVideo(args.video, env) if args.video else None
    if not args.json:
        order = " ".join(c.label for c in env.track.corners)
        direction = "reversed" if args.reverse else "file order"
        print(f"{shown_path(args.track)} ({direction}), corners met in order {order}:", flush=True)
    plot_staged: Path | None = None
    previous = signal.signal(signal.SIGTERM, raise_terminated)
    try:
        for lap in range(args.laps):
            # Per-lap bar: percent of the track driven; a lap's line is printed as it ends.
            with progress_bar(
                100, f"lap {lap + 1}/{args.laps}", unit="%", enabled=not args.quiet, leave=False
            ) as bar:

                def on_step(step: Any, lap: int = lap) -> None:
                    info = step.moment.info
                    step_note = f"step {info['step']}/{info['max_steps']}"
                    _advance(bar, max(0, min(100, round(100 * info["lap_fraction"]))), step_note)
                    if video is not None:
                        frame, values = step.moment.frame, step.percept.values
                        video.add(frame, values, info, lap=lap + 1, command=step.command)

                info, trajectory, steps = run_trial(
                    env, controller, seed=args.seed if lap == 0 else None, on_loop_step=on_step
                )
            failure = info["failure"] or (None if info["success"] else "timeout")
            laps.append(
                {
                    "lap": lap + 1,
                    "success": info["success"],
                    "failure": failure,
                    "failed_corner": None if info["success"] else env.episode.next_corner,
                    "corners_reached": info["corners_reached"],
                    "corners_negotiated": info["corners_negotiated"],
                    "steps": steps,
                    "progress_m": round(info["progress_m"], 3),
                }
            )
            trajectories.append(TrackRun(trajectory, info["success"], failure, f"lap {lap + 1}"))
            if not args.json:
                print(_lap_line(laps[-1]), flush=True)
        # Both outputs or neither: the plot is drawn and written under a hidden name first, so
        # a failure or an interrupt until the video is complete leaves an earlier pair as it was.
        if args.plot:
            direction = "reversed" if args.reverse else "file order"
            if env.track.closed:
                x, y = env.track.vertices[:, 0], env.track.vertices[:, 1]  # in driving order
                area2 = float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
                direction = "counter-clockwise" if area2 > 0 else "clockwise"
            controller_name = shown_path(Path(args.controller).name)
            title = f"{shown_path(args.track)} track, {direction}: {controller_name}"
            picture = laps_plot(
                env.track,
                trajectories,
                title=title,
                finish_m=env.episode.goal_progress_m,
                start_pose=env.episode.start_pose(),
            )
            plot_staged = _temporary_beside(Path(args.plot))
            write_png(str(plot_staged), picture)
        if video is not None:
            video.close()
        if plot_staged is not None:
            replace_file(plot_staged, args.plot)
            plot_staged = None
    except (KeyboardInterrupt, Terminated) as exc:
        code = interrupted_exit_code(exc)
        note = f"lfd-track drive: interrupted after {len(laps)} of {args.laps} laps"
        if video is not None:
            # Half a video is not kept: the encoder, stopped too, may leave it unplayable.
            video.discard()
            left = "is unchanged" if taken(video.path) else "was not written"
            note += f"; the partial video is discarded ({shown_path(video.path)} {left})"
        print(note, file=sys.stderr)
        return code
    except BaseException:
        if video is not None:
            video.discard()
        raise
    finally:
        signal.signal(signal.SIGTERM, previous)
        if plot_staged is not None:
            plot_staged.unlink(missing_ok=True)
    if args.json:
        track = shown_path(args.track)  # JSON holds text only: undecodable bytes as \\x escapes
        print(json.dumps({"track": track, "reverse": args.reverse, "laps": laps}, indent=2))
    else:
        print(f"  {sum(lap['success'] for lap in laps)}/{len(laps)} successful")
    return EXIT_OK


# --------------------------------------------------------------------------------- benchmark
def _whole_number_in(low: int, high: int) -> Any:
    """An argparse type: a whole number in ``low..high``; the error never prints a huge number
    whole."""

    def parse(text: str) -> int:
        from .learning.fit import shown_int

        try:
            value = int(text)
        except ValueError:
            shown = text if len(text) <= 30 else f"{text[:30]}... ({len(text)} characters)"
            raise argparse.ArgumentTypeError(f"expected a whole number, got {shown!r}") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be at least {low}, got {shown_int(value)}")
        if value > high:
            raise argparse.ArgumentTypeError(f"must be at most {high}, got {shown_int(value)}")
        return value

    return parse


def _cmd_benchmark(args: argparse.Namespace) -> int:
    from .benchmark.output import staged_output
    from .benchmark.report import write_benchmark_outputs
    from .benchmark.runner import (
        MAX_WORKERS,
        BenchmarkConfig,
        check_tracks,
        check_workers,
        run_benchmark,
    )
    from .demo.demonstrator import HumanConfig
    from .progress import progress_bar
    from .teaching.memory import MemoryConfig

    repetitions = 1 if args.quick and args.repetitions is None else (args.repetitions or 10)
    trials = args.trials or (1 if args.quick else 3)
    config = BenchmarkConfig(
        repetitions=repetitions,
        seed=args.seed,
        trials_per_direction=trials,
        preset=args.preset,
        human=HumanConfig(careful=not args.careless, turnarounds=args.turnarounds),
        keep_learning=args.keep_learning,
        method=args.method,
        test_tracks=("testing", *args.test_track),
        memory=MemoryConfig(kind=args.memory),
        mirror=args.mirror,
        demo_track=args.demo_track,
    )
    # Track and preset names are recorded in results.json and report.md, which hold text only.
    for what, name in (
        ("preset", args.preset),
        ("demonstration track", args.demo_track),
        *(("test track", track) for track in args.test_track),
    ):
        refuse_undecodable(name, what)
    refuse_unsafe_output(args.out, folder=True)
    workers = args.workers or min(_cores(), MAX_WORKERS)
    check_workers(workers)
    # A bad preset, a track that is not a loop with corners or whose ground texture would be too
    # big with this preset fails here, before anything is created.
    check_tracks(config)
    out = Path(args.out)
    # The run goes to a staging folder and replaces the previous output only once it has
    # succeeded: a failure at any point leaves the previous output as it was. SIGTERM stops it
    # like Ctrl-C, so the staging folder is removed too.
    previous = signal.signal(signal.SIGTERM, raise_terminated)
    try:
        with staged_output(out) as stage:
            start = time.perf_counter()
            with progress_bar(
                config.repetitions, "benchmark", unit=" repetitions", enabled=not args.quiet
            ) as bar:

                def tick(result: Any) -> None:
                    wins = sum(o.success for o in result.outcomes)
                    bar.set_postfix_str(
                        f"repetition {result.index}: {wins}/{len(result.outcomes)} trials"
                        " succeeded",
                        refresh=False,
                    )
                    bar.update(1)

                reps = run_benchmark(config, stage / "repetitions", workers=workers, progress=tick)
            wall = time.perf_counter() - start
            text = write_benchmark_outputs(stage, config, reps, wall_s=wall, workers=workers)
    except (KeyboardInterrupt, Terminated) as exc:
        code = interrupted_exit_code(exc)
        print(f"lfd-track benchmark: interrupted; {shown_path(out)} is as it was", file=sys.stderr)
        return code
    finally:
        signal.signal(signal.SIGTERM, previous)
    print(text)
    print(
        f"\nreport: {shown_path(out / 'report.md')}\nresults: {shown_path(out / 'results.json')}"
        f"\nplots: {shown_path(out / 'trajectories.png')}, {shown_path(out / 'fitness.png')}"
    )
    return EXIT_OK


# --------------------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    from .benchmark.methods import METHODS
    from .benchmark.runner import MAX_REPETITIONS, MAX_SEED, MAX_TRIALS_PER_DIRECTION, MAX_WORKERS
    from .teaching.memory import MEMORY_KINDS
    from .teaching.scripted import TURNAROUND_RULES

    """The ``lfd-track`` argument parser."""
    parser = _Parser(
        prog="lfd-track",
        description="Learning from demonstration with encapsulated evolution on a felt-track rover.",
        epilog="Outputs: an existing file is replaced only where a command says so (--force);"
        " an output name that is a symbolic link, a device, a FIFO or a socket is always refused."
        " Track and preset names recorded in a recording or in benchmark results must be UTF-8.",
    )
    parser.add_argument(
        "--quiet",
        "-q",
        action="store_true",
        help="no progress bars (they are shown only when stderr is a terminal anyway)",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    demo = sub.add_parser(
        "demo",
        help="record a scripted human demonstration in the simulator",
        description="Drive the paper's demonstration protocol with the scripted human and record every case.",
    )
    demo.add_argument(
        "--track", default="training", help="open track to demonstrate on (default: training)"
    )
    demo.add_argument(
        "--seed", type=_seed, default=0, help="seed of the human and the world (default: 0)"
    )
    demo.add_argument(
        "--preset", default="paper", help="environment preset name or TOML path (default: paper)"
    )
    demo.add_argument(
        "--careless",
        action="store_true",
        help="keep learning the road library while the safe box is off the felt (the paper's warning)",
    )
    demo.add_argument("--force", action="store_true", help="replace an existing output file")
    demo.add_argument("--out", required=True, help="demonstration file to write (.lfdemo)")
    demo.set_defaults(func=_cmd_demo)

    evo = sub.add_parser(
        "evolve",
        help="evolve a controller from a demonstration",
        description="Run the paper's GA (Table 1) on a demonstration; writes the controller JSON and a fitness-curve PNG beside it.",
    )
    evo.add_argument("demo", help="demonstration file (.lfdemo)")
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
    evo.add_argument("--out", required=True, help="controller file to write (.json)")
    evo.set_defaults(func=_cmd_evolve)

    drive = sub.add_parser(
        "drive",
        help="drive a controller autonomously in the simulator",
        description="Run a saved controller for N laps and report per-lap corner outcomes.",
    )
    drive.add_argument("controller", help="controller file (.json)")
    drive.add_argument(
        "--track", default="testing", help="track name or TOML path (default: testing)"
    )
    drive.add_argument(
        "--reverse", action="store_true", help="drive against the file order (testing: clockwise)"
    )
    drive.add_argument("--laps", type=_positive_int, default=1, help="episodes to run (default: 1)")
    drive.add_argument("--seed", type=_seed, default=0, help="world seed (default: 0)")
    drive.add_argument(
        "--preset", default="paper", help="environment preset name or TOML path (default: paper)"
    )
    drive.add_argument(
        "--video",
        metavar="FILE",
        help="write a video (.mp4 or .webm, VP9): camera view with road values beside the"
        " top-down view, lap number and command",
    )
    drive.add_argument(
        "--plot", metavar="FILE", help="write a PNG of each lap's path, coloured by outcome"
    )
    drive.add_argument(
        "--keep-learning",
        action="store_true",
        help="let the road library keep learning from the safe box while driving (default: frozen)",
    )
    drive.add_argument("--json", action="store_true", help="print the outcomes as JSON")
    drive.set_defaults(func=_cmd_drive)

    bench = sub.add_parser(
        "benchmark",
        help="reproduce the paper's Tables 2 and 3",
        description="The paper protocol: per repetition a fresh demonstration, evolution, then 3 runs each way on the training track and 3 laps each way on the testing track.",
    )
    bench.add_argument(
        "--repetitions",
        type=_whole_number_in(1, MAX_REPETITIONS),
        default=None,
        help=f"repetitions, at most {MAX_REPETITIONS} (default: 10; 1 with --quick)",
    )
    bench.add_argument(
        "--trials",
        type=_whole_number_in(1, MAX_TRIALS_PER_DIRECTION),
        default=None,
        help=f"runs per direction per repetition, at most {MAX_TRIALS_PER_DIRECTION}"
        " (default: 3; 1 with --quick)",
    )
    bench.add_argument(
        "--seed",
        type=_whole_number_in(0, MAX_SEED),
        default=0,
        help=f"benchmark seed, 0..{MAX_SEED} (default: 0)",
    )
    bench.add_argument(
        "--workers",
        type=_whole_number_in(1, MAX_WORKERS),
        default=None,
        help=f"parallel processes, at most {MAX_WORKERS}; results do not depend on it"
        f" (default: the number of cores, here {_cores()})",
    )
    bench.add_argument(
        "--preset", default="paper", help="environment preset name or TOML path (default: paper)"
    )
    bench.add_argument(
        "--test-track",
        action="append",
        default=[],
        metavar="TRACK",
        help="also lap this loop (name or .toml path) both ways, as many laps as on the testing"
        " track; repeatable; results per track in results.json",
    )
    bench.add_argument(
        "--demo-track",
        default="training",
        metavar="TRACK",
        help="open track (name or .toml path) the human demonstrates on, and HG-DAgger's rounds"
        " drive (default: the paper's training track, which is also scored either way)",
    )
    bench.add_argument(
        "--method",
        choices=METHODS,
        default="paper",
        help="how each repetition learns: paper (demonstrate, then evolve), online (evolve while"
        " demonstrating, policy takes over, human corrects), hg-dagger (rounds of runs with"
        " interventions), bc, cma-es (default: paper)",
    )
    bench.add_argument(
        "--turnarounds",
        choices=TURNAROUND_RULES,
        default="alternate",
        help="the human's turn-arounds at the training track's ends: alternate (the paper's),"
        " one_sided, unrecorded, toward_last_bend (default: alternate)",
    )
    bench.add_argument(
        "--memory",
        choices=MEMORY_KINDS,
        default="none",
        help="memory inputs of the policy after the 40 road values: none (the paper's) or"
        " last_bend (the side of the last bend; pair it with --turnarounds toward_last_bend)",
    )
    bench.add_argument(
        "--mirror",
        action="store_true",
        help="learn from the cases and their mirror images (left and right swapped)",
    )
    bench.add_argument(
        "--careless",
        action="store_true",
        help="demonstrator keeps learning while the safe box is off the felt",
    )
    bench.add_argument(
        "--keep-learning",
        action="store_true",
        help="road library keeps learning during autonomous runs (default: frozen, as in the paper)",
    )
    bench.add_argument(
        "--quick", action="store_true", help="one repetition, one run per direction (a smoke test)"
    )
    bench.add_argument(
        "--out", required=True, help="output folder (results.json, report.md, plots)"
    )
    bench.set_defaults(func=_cmd_benchmark)

    from .study.cli import add_study_parser

    add_study_parser(sub)

    from .web.cli import add_teach_parser

    add_teach_parser(sub)

    try:
        from .hardware.cli import add_hardware_parser
    except ImportError:  # pragma: no cover - the hardware extra is part of the package
        pass
    else:
        add_hardware_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``lfd-track`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("lfd-track: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except OSError as exc:
        where = exc.filename if exc.filename is not None else ""
        message = (
            f"{where}: {exc.strerror}" if where and exc.strerror else str(exc) or type(exc).__name__
        )
        print(f"lfd-track {args.command}: {message.splitlines()[0]}", file=sys.stderr)
        return EXIT_ERROR
    except (LfdTrackError, ValueError, OverflowError, RecursionError) as exc:
        message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        print(f"lfd-track {args.command}: {message}", file=sys.stderr)
        return EXIT_ERROR


if __name__ == "__main__":
    sys.exit(main())
