"""``lfd-track drive``: run a saved controller for laps in the simulator, report each lap's
corners, and write a video and a plot of the laps with its numbers (all or none)."""

from __future__ import annotations

import argparse
import json
import signal
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ..benchmark import runner
from ..envs.track_env import LfDTrackEnv
from ..errors import LfdTrackError
from ..policy.controller import Controller
from ..utils.outputs import same_file, shown_path, taken
from ..utils.signals import Terminated, interrupted_exit_code, raise_terminated
from .outputs import advance, check_output
from .types import EXIT_OK
from .types import non_negative_int as _seed
from .types import positive_int as _positive_int


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``drive`` to the ``lfd-track`` commands."""
    drive = subparsers.add_parser(
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
        "--plot",
        metavar="FILE",
        help="write a PNG of each lap's path, coloured by outcome, and the paths as CSV beside it"
        " (FILE with the suffix .csv)",
    )
    drive.add_argument(
        "--keep-learning",
        action="store_true",
        help="let the road library keep learning from the safe box while driving (default: frozen)",
    )
    drive.add_argument("--json", action="store_true", help="print the outcomes as JSON")
    drive.set_defaults(func=run)
    return drive


def _lap_line(lap: dict[str, Any]) -> str:
    if lap["success"]:
        outcome = "success"
    elif lap["failed_corner"] is None:
        outcome = f"{lap['failure']} after the last corner"
    else:
        outcome = f"{lap['failure']} at corner {lap['failed_corner']}"
    negotiated = " ".join(lap["corners_negotiated"]) or "-"
    return f"  lap {lap['lap']}: {outcome}; negotiated {negotiated} ({lap['steps']} steps)"


def run(args: argparse.Namespace) -> int:
    """The ``drive`` command."""
    # Lazy: the drawing, progress-bar and video stack (OpenCV, tqdm) loads only when it runs.
    from ..utils.progress import progress_bar
    from ..viz import plot_data, plots
    from ..viz.video import DriveVideo

    controller = Controller.load(args.controller)
    controller.learn = controller.learn or args.keep_learning
    inputs = [("controller", args.controller), ("track", args.track), ("preset", args.preset)]
    plot_numbers = plot_data.data_path(args.plot) if args.plot else None
    for out in (args.video, args.plot, plot_numbers):
        if out:
            check_output(out, inputs)
    if args.video and args.plot and same_file(args.video, args.plot):
        raise LfdTrackError(f"{shown_path(args.plot)}: given as both --video and --plot")
    if plot_numbers is not None and same_file(args.plot, plot_numbers):
        raise LfdTrackError(
            f"{shown_path(args.plot)}: the plot's numbers are written beside it with the suffix"
            " .csv; give the plot another suffix (e.g. .png)"
        )
    if args.video and plot_numbers is not None and same_file(args.video, plot_numbers):
        raise LfdTrackError(
            f"{shown_path(args.video)}: given as --video and is where --plot's numbers go"
        )
    env = LfDTrackEnv(track=args.track, reverse=args.reverse, preset=args.preset)
    laps: list[dict[str, Any]] = []
    trajectories = []
    video = DriveVideo(args.video, env) if args.video else None
    if not args.json:
        order = " ".join(c.label for c in env.track.corners)
        direction = "reversed" if args.reverse else "file order"
        print(f"{shown_path(args.track)} ({direction}), corners met in order {order}:", flush=True)
    plot_staged = plot_data.StagedFiles()
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
                    advance(bar, max(0, min(100, round(100 * info["lap_fraction"]))), step_note)
                    if video is not None:
                        frame, values = step.moment.frame, step.percept.values
                        video.add(frame, values, info, lap=lap + 1, command=step.command)

                info, trajectory, steps = runner.run_trial(
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
            trajectories.append(
                plots.TrackRun(trajectory, info["success"], failure, f"lap {lap + 1}")
            )
            if not args.json:
                print(_lap_line(laps[-1]), flush=True)
        # All outputs or none: the plot and its numbers are drawn and written under hidden names
        # first, so a failure or an interrupt until the video is complete leaves the earlier
        # files as they were.
        if args.plot:
            direction = "reversed" if args.reverse else "file order"
            if env.track.closed:
                x, y = env.track.vertices[:, 0], env.track.vertices[:, 1]  # in driving order
                area2 = float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
                direction = "counter-clockwise" if area2 > 0 else "clockwise"
            controller_name = shown_path(Path(args.controller).name)
            title = f"{shown_path(args.track)} track, {direction}: {controller_name}"
            picture = plots.laps_plot(
                env.track,
                trajectories,
                title=title,
                finish_m=env.episode.goal_progress_m,
                start_pose=env.episode.start_pose(),
            )
            plot_data.stage_picture(
                args.plot, picture, plot_data.laps_table(trajectories), plot_staged
            )
        if video is not None:
            video.close()
        plot_staged.publish()
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
        plot_staged.discard()
    if args.json:
        track = shown_path(args.track)  # JSON holds text only: undecodable bytes as \\x escapes
        print(json.dumps({"track": track, "reverse": args.reverse, "laps": laps}, indent=2))
    else:
        print(f"  {sum(lap['success'] for lap in laps)}/{len(laps)} successful")
    return EXIT_OK
