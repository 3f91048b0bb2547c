"""``lfd-track teach``: open a teaching session and serve its page until Ctrl-C.

The arguments become a :class:`~lfd_track.web.session.TeachConfig`; the web stack (and, for the
real robot, the serial link and the camera stream) is imported only when the command runs.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ..errors import LfdTrackError
from ..methods.online import ONLINE_LEARNERS, OnlineConfig
from ..policy.features import DEFAULT_FEATURES, FEATURE_SETS
from ..policy.memory import MEMORY_KINDS
from ..policy.mlp import MAX_MEMBERS
from ..utils.outputs import refuse_undecodable, refuse_unsafe_output
from ..utils.signals import stop_signals_interrupt
from ..web.defaults import DEFAULT_FPS, DEFAULT_HOST, DEFAULT_PORT
from .types import (
    EXIT_OK,
    add_map_arguments,
    float_in,
    memory_from_args,
    port,
    share,
    unit_interval,
    whole_number_in,
)
from .types import non_negative_int as _count
from .types import positive_int as _positive_int

FPS_RANGE = (1.0, 30.0)
"""[frames/s] ``--fps`` allowed: the page's status comes with the view (slower, and it lags);
a phone camera gives 30 at most."""
PERIOD_RANGE = (0.02, 5.0)
"""[s] ``--period`` allowed: a preset's bounds on a control period (``rover.control_period_s``
in :data:`lfd_track.envs.presets.BOUNDS`; not imported here, to keep the command line quick)."""


def teach_config(args: argparse.Namespace) -> Any:
    """The :class:`~lfd_track.web.session.TeachConfig` the arguments ask for."""
    from ..web.session import TeachConfig  # lazy: the web stack

    if args.features == "none" and args.memory == "none":
        raise LfdTrackError("--features none reads the memory inputs alone: give --memory")
    if args.online_learner is not None and not args.online:
        raise LfdTrackError("--online-learner is for --online: give --online")
    if args.mirror and not args.online:
        raise LfdTrackError("--mirror is for --online (the learner's cases): give --online")
    learner = args.online_learner or "ga"
    if args.bc_class_balance is not None and learner != "bc":
        raise LfdTrackError("--bc-class-balance is for --online --online-learner bc")
    if args.bc_ensemble is not None and learner != "bc":
        raise LfdTrackError("--bc-ensemble is for --online --online-learner bc")
    for flag, value in (
        ("--generations-per-case", args.generations_per_case),
        ("--population", args.population),
        ("--mutation-delta", args.mutation_delta),
    ):
        if learner != "ga" and value is not None:
            raise LfdTrackError(f"{flag} is for --online-learner ga, not {learner}")
    try:
        memory = memory_from_args(args)
    except ValueError as exc:
        raise LfdTrackError(str(exc)) from None
    profile = None
    if args.profile is not None:
        from ..hardware.profile import load_profile  # lazy: read only when given

        robot = load_profile(args.profile)
        note = robot.period_note(args.profile, args.period or 0.4)  # the hardware's default
        if note is not None:
            print(note, file=sys.stderr)
        profile = robot.geometry
    return TeachConfig(
        out=Path(args.out),
        backend=args.backend,
        track=args.track,
        preset=args.preset,
        seed=args.seed,
        camera=args.camera,
        serial=args.serial,
        period_s=args.period,
        profile=profile,
        online=args.online,
        takeover=OnlineConfig(
            generations_per_case=args.generations_per_case or OnlineConfig.generations_per_case,
            learner=learner,
            window=args.takeover_window,
            threshold=args.takeover_threshold,
        ),
        population_size=40 if args.population is None else args.population,
        memory=memory,
        features=args.features,
        ga_bias=args.ga_bias,
        mutation_delta=0.1 if args.mutation_delta is None else args.mutation_delta,
        class_balance=1.0 if args.bc_class_balance is None else args.bc_class_balance,
        ensemble=1 if args.bc_ensemble is None else args.bc_ensemble,
        mirror=args.mirror,
        library_only=args.library_only,
        force=args.force,
        fps=args.fps,
    )


def run(args: argparse.Namespace) -> int:
    """The ``teach`` command: open the session, serve the page, close everything on exit."""
    # Lazy: the web stack (and the robot's link and camera) load only when teach runs.
    from ..web import session as station_session
    from ..web.app import create_app, is_loopback, new_token
    from ..web.server import StationServer, bind_socket, station_url

    if args.backend == "hardware" and not (args.camera and args.serial):
        raise LfdTrackError("--backend hardware needs --camera URL and --serial URL")
    if args.backend == "sim" and (args.camera or args.serial):
        raise LfdTrackError("--camera and --serial are for --backend hardware")
    if args.backend == "sim" and args.profile:
        raise LfdTrackError(
            "--profile is for --backend hardware (in the simulator the preset is the robot)"
        )
    out = Path(args.out)
    refuse_unsafe_output(out)
    for what, name in (("track", args.track), ("preset", args.preset)):
        refuse_undecodable(name, what)
    if out.exists() and not args.force:
        raise LfdTrackError(f"{out}: already exists (use --force to replace it)")
    replacing = out.exists()  # kept until the new recording holds a case
    config = teach_config(args)
    token = None if is_loopback(args.host) else new_token()
    sock = bind_socket(args.host, args.port)
    try:
        # Opening a camera or a serial link can take seconds: SIGTERM or SIGHUP meanwhile ends
        # it like Ctrl-C, so the session's clean-up runs (no empty recording is left behind).
        with stop_signals_interrupt():
            session = station_session.open_session(config)
    except BaseException:
        sock.close()
        raise
    try:
        server = StationServer(create_app(session, token=token, fps=args.fps), sock)
        print(
            f"teaching station ({args.backend}): open {station_url(args.host, server.port, token)}"
        )
        if token:
            print("the token in the URL is required: share it only with who may drive the robot")
        print("recording to", out)
        print("press Ctrl-C to stop", flush=True)
        server.serve()
    finally:
        session.close()
        sock.close()
    status = session.status()
    if replacing and not status["cases"]:
        return EXIT_OK  # the recording has said that nothing was recorded and the file is unchanged
    counts = status.get("counts", {})
    print(
        f"{out}: {status['cases']} cases ({counts.get('forward', 0)} forward, "
        f"{counts.get('left', 0)} left, {counts.get('right', 0)} right"
        + (f", {status['corrections']} corrections" if args.online else "")
        + f"), library {status['library_models']} models"
    )
    return EXIT_OK


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``teach`` to the ``lfd-track`` commands."""
    teach = subparsers.add_parser(
        "teach",
        help="teach from a browser (laptop or phone): live view, buttons, recording",
        description=(
            "Serve a teaching page for the simulated or the real robot: live camera view with "
            "road values, forward/left/right buttons and arrow keys, stop (space), pause library "
            "learning; with --online the policy learns as you teach (the GA, or backprop with "
            "--online-learner bc) and can take over. Every "
            "case is written to --out as it is given (crash-safe .lfdemo, usable by evolve)."
        ),
    )
    teach.add_argument(
        "--backend", choices=("sim", "hardware"), default="sim", help="robot (default: sim)"
    )
    teach.add_argument(
        "--track", default="training", help="simulator track name or TOML path (default: training)"
    )
    teach.add_argument("--preset", default="paper", help="simulator preset name or TOML path")
    teach.add_argument("--seed", type=_count, default=0, help="seed of the world and the learner")
    teach.add_argument("--camera", metavar="URL", help="phone camera stream (hardware)")
    teach.add_argument("--serial", metavar="URL", help="serial port or pyserial URL (hardware)")
    teach.add_argument(
        "--period",
        type=float_in(*PERIOD_RANGE),
        default=None,
        metavar="S",
        help="control period [s], {:g}..{:g}: the real robot's command length; in the simulator the "
        "pace of commands (default: the preset's, 0.4 s)".format(*PERIOD_RANGE),
    )
    teach.add_argument(
        "--profile",
        metavar="FILE",
        default=None,
        help="robot profile written by `lfd-track hardware calibrate` (hardware): the robot's"
        " measured forward step and pivot for the fresh_felt map (default: the paper preset's"
        " camera and rates at --period)",
    )
    teach.add_argument(
        "--online",
        action="store_true",
        help="evolve a policy while you teach; it offers to take over when it agrees with you",
    )
    teach.add_argument(
        "--online-learner",
        choices=ONLINE_LEARNERS,
        default=None,
        help="with --online: what learns as you teach, the GA or backprop (bc: the bc method's"
        f" settings, biases with --ga-bias, {OnlineConfig.epochs_per_case} Adam epochs on all"
        " cases after each new case; default: ga)",
    )
    teach.add_argument(
        "--generations-per-case",
        type=_positive_int,
        default=None,
        metavar="N",
        help="with --online: GA generations run after each new case (default 2)",
    )
    teach.add_argument(
        "--takeover-window",
        type=_positive_int,
        default=10,
        metavar="K",
        help="with --online: agreement is measured over the last K human commands (default 10)",
    )
    teach.add_argument(
        "--takeover-threshold",
        type=share,
        default=0.9,
        metavar="F",
        help="with --online: share of those K the policy must agree on to be offered the wheel "
        "(default 0.9)",
    )
    teach.add_argument(
        "--population",
        type=_positive_int,
        default=None,
        metavar="P",
        help="with --online (learner ga): GA population (default 40, the paper's)",
    )
    teach.add_argument(
        "--memory",
        choices=MEMORY_KINDS,
        default="none",
        help="memory inputs recorded with every case for the policy to read (see"
        " docs/learning-api.md; default none, the paper's 40 road values)",
    )
    add_map_arguments(teach)
    teach.add_argument(
        "--features",
        choices=FEATURE_SETS,
        default=DEFAULT_FEATURES,
        help="with --online: per-region inputs of the policy: road_values (the paper's 40,"
        " default), road_values+colour (160), near_felt (2) or none (its memory inputs alone;"
        " needs --memory)",
    )
    teach.add_argument(
        "--ga-bias",
        action="store_true",
        help="with --online: networks with biases, GA or backprop (the map-only policy kind needs"
        " them to reach steep weights)",
    )
    teach.add_argument(
        "--bc-class-balance",
        type=unit_interval,
        default=None,
        metavar="K",
        help="with --online-learner bc: each case weighs n_e ** -K, n_e the cases of its command"
        " (default 1: each command the same; 0: each case the same; the human-taught goal's"
        " round 15 chose 0.5)",
    )
    teach.add_argument(
        "--bc-ensemble",
        type=whole_number_in(1, MAX_MEMBERS),
        default=None,
        metavar="K",
        help="with --online-learner bc: recorded in the recording's online settings, for a"
        " controller fitted from it later as K networks from their own starting weights that"
        " drive by the mean of their outputs (default 1); while teaching, the policy that may"
        " take over is one network",
    )
    teach.add_argument(
        "--mutation-delta",
        type=float_in(0.001, 10.0),
        default=None,
        metavar="D",
        help="with --online (learner ga): the GA's mutation step (default 0.1, the paper's)",
    )
    teach.add_argument(
        "--mirror",
        action="store_true",
        help="with --online: the learner fits the cases and their mirror images (left and right"
        " swapped), as benchmark --mirror does; the recording holds the cases as taught",
    )
    teach.add_argument(
        "--library-only",
        type=_count,
        default=0,
        metavar="N",
        help="first N commands only build the road library and are not recorded (default 0)",
    )
    teach.add_argument("--out", required=True, help="demonstration file to write (.lfdemo)")
    teach.add_argument("--force", action="store_true", help="replace an existing output file")
    teach.add_argument(
        "--host",
        default=DEFAULT_HOST,
        help="address to listen on (default 127.0.0.1; any other needs the printed token)",
    )
    teach.add_argument(
        "--port", type=port, default=DEFAULT_PORT, help="port (default 8765; 0 picks a free one)"
    )
    teach.add_argument(
        "--fps",
        type=float_in(*FPS_RANGE),
        default=DEFAULT_FPS,
        help=f"live view frames/s, {FPS_RANGE[0]:g}..{FPS_RANGE[1]:g} (default 10)",
    )
    teach.set_defaults(func=run)
    return teach
