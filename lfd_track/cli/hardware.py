"""``lfd-track hardware …``: simulated board, link check, calibration, autonomous drive,
tele-operated demo.

``add_parser(subparsers)`` adds the ``hardware`` command to the main CLI. Each subcommand's
handler is stored as ``func`` on the parsed namespace, takes the namespace and returns the exit
code; user errors (bad URL, lost link, bad controller file) print one line to stderr and return
1; Ctrl-C, SIGTERM and SIGHUP stop the motors and return 130.
``python -m lfd_track.cli.hardware`` runs the same commands stand-alone.

The host side of the robot (the serial link, the camera stream, simavr) is imported inside each
handler: it is an optional part, and loading it is what ``lfd-track --help`` must not wait for.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import threading
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..errors import LfdTrackError
from ..policy.controller import Controller
from ..policy.map_geometry import MapGeometry, hardware_geometry
from ..policy.memory import MEMORY_KINDS, memory_config
from ..teaching import Arbiter, TeachingLoop
from ..utils.outputs import refuse_undecodable, refuse_unsafe_output
from ..utils.signals import EXIT_INTERRUPTED, stop_signals_interrupt
from .types import EXIT_ERROR, EXIT_OK, non_negative_int, positive_int


def _fail(message: str) -> int:
    print(f"lfd-track hardware: {message}", file=sys.stderr)
    return EXIT_ERROR


def _guarded(handler: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
    """Turn user-caused errors into one line and an exit code (never a traceback)."""

    def run(args: argparse.Namespace) -> int:
        try:
            # SIGTERM and SIGHUP (kill, a closed terminal) end the command as Ctrl-C does: the
            # motors are stopped, the terminal restored and a recording closed with its footer.
            with stop_signals_interrupt():
                return handler(args)
        except KeyboardInterrupt:
            print("interrupted: motors stopped", file=sys.stderr)
            return EXIT_INTERRUPTED
        except (LfdTrackError, OSError, ValueError) as exc:
            return _fail(str(exc))

    return run


# ---------------------------------------------------------------------------------------- sim
def _cmd_sim(args: argparse.Namespace) -> int:
    from ..hardware.simavr import FIRMWARE_BAUD, SimavrError, SimulatedBoard

    board = SimulatedBoard(build_dir=args.build_dir, keep_files=args.keep_log)
    log_path = None
    try:
        with stop_signals_interrupt():
            try:
                board.start()
            except SimavrError as exc:
                return _fail(str(exc))
            except KeyboardInterrupt:
                print("interrupted before the simulated board started", file=sys.stderr)
                return EXIT_INTERRUPTED
            log_path = board.log_path
            try:  # a stop request may come as soon as the URL is out, even before the wait
                print(
                    f"simulated board running; serial URL: {board.serial_url} "
                    f"(baud {FIRMWARE_BAUD})"
                )
                print("motor log:", log_path)
                print("press Ctrl-C to stop", flush=True)
                threading.Event().wait()  # until Ctrl-C, SIGTERM or SIGHUP
            except KeyboardInterrupt:
                print("stopping the simulated board", flush=True)
    finally:
        board.close()  # stops the harness; removes its files unless --keep-log
    if args.keep_log and log_path is not None:
        print("motor log kept:", log_path)
    return EXIT_OK


# -------------------------------------------------------------------------------------- check
def _cmd_check(args: argparse.Namespace) -> int:
    from ..hardware import wire
    from ..hardware.link import RobotLink

    link = RobotLink(args.serial, baudrate=args.baud, boot_wait_s=args.boot_wait)
    if args.boot_wait > 0:
        print(
            f"waiting up to {args.boot_wait:g} s for the board's boot frame (a USB board resets "
            "when the port opens; reset or power-cycle any other board now)",
            flush=True,
        )
    with link:
        # Firmware 1.1 and later answer the version query V at any time; older firmware names
        # its version only in the boot frame, which a board that booted before the port opened
        # has already sent.
        board = link.query_version()
        if board is not None:
            version = f"{board.version} (last reset: {board.reset_cause_text})"
        elif link.firmware_version:
            version = f"{link.firmware_version} (from its boot frame)"
        else:
            version = (
                "unknown (the board does not answer the version query, so its firmware is older "
                "than 1.1, and its boot frame was not seen; reset or power-cycle the board while "
                "check waits for it with --boot-wait S)"
            )
        print(f"connected to {args.serial}; firmware version: {version}")
        was_latched = link.ping().estopped
        if was_latched:
            print(
                "note: the board's e-stop was latched when check connected (the board boots "
                "latched after a watchdog or brown-out reset); check leaves it latched"
            )
        rtts = [link.ping().rtt_ms for _ in range(args.pings)]
        stats = link.stats()
        print(
            f"ping round trip over {args.pings}: min {min(rtts):.1f} ms, median "
            f"{statistics.median(rtts):.1f} ms, max {max(rtts):.1f} ms; missed {stats.missed}"
        )
        problems = []
        # Safety checks that never move the robot: a ping does not start motion, the e-stop
        # latches and refuses drives, clearing it leaves the motors off, bad periods are refused.
        if link.ping().moving:
            problems.append("the board reports moving motors after a ping")
        if not link.estop().estopped:
            problems.append("e-stop was not latched")
        refused = link.drive("F")
        if refused.accepted or refused.rejected != wire.REASON_ESTOP:
            problems.append("a drive frame was accepted while the e-stop was latched")
        cleared = link.clear_estop()
        if cleared.estopped or cleared.moving:
            problems.append("clearing the e-stop restarted the motors or did not clear")
        try:
            bad = link.request(wire.SET_WATCHDOG, "10")  # below the 50 ms minimum
            if bad.accepted:
                problems.append("the board accepted a 10 ms watchdog period")
        finally:
            link.set_watchdog_ms(args.watchdog_ms)
        if args.lease_test and not was_latched:
            problems += _lease_test(link, args.watchdog_ms)
        elif args.lease_test:
            print("lease test skipped: it would need the e-stop cleared")
        if was_latched and not link.estop().estopped:
            problems.append("the e-stop could not be latched again")
        for problem in problems:
            print(f"FAIL: {problem}")
        if not problems:
            print(
                "OK: ping, e-stop latch, e-stop clear, watchdog range"
                + (", lease watchdog" if args.lease_test else "")
            )
    return EXIT_OK if not problems else EXIT_ERROR


def _lease_test(link: Any, watchdog_ms: int) -> list[str]:
    """Drive forward once without refreshing and time the board's watchdog stop (``$W``).

    This moves the motors for one watchdog period: the operator must lift the robot first.
    """
    ack = link.drive("F", lease_s=0)  # sent once; the board must stop on its own
    if not ack.moving:
        link.stop()
        return [f"the board did not start the motors for the lease test (state {ack.state})"]
    waited = link.wait_for_watchdog_stop(timeout_s=watchdog_ms / 1000 * 2 + 0.5)
    link.stop()
    if waited is None:
        return [f"no watchdog stop within {watchdog_ms * 2 + 500} ms of the last drive frame"]
    print(f"lease watchdog stopped the motors {waited * 1000:.0f} ms after the drive was acked")
    if waited * 1000 > watchdog_ms + 150:
        # Late rather than missing: usually latency of the $W message itself (Bluetooth).
        print(f"warning: later than the {watchdog_ms} ms period; check the link latency")
    return []


# -------------------------------------------------------------------------------------- drive
def _make_env(args: argparse.Namespace, **kwargs: Any) -> Any:
    from ..hardware.env import HardwareEnv

    return HardwareEnv(
        camera_url=args.camera,
        serial_url=args.serial,
        watchdog_ms=args.watchdog_ms,
        control_period_s=args.period,
        link_options={"baudrate": args.baud, "boot_wait_s": args.boot_wait},
        **kwargs,
    )


def _profile_geometry(args: argparse.Namespace) -> MapGeometry | None:
    """The map geometry of ``--profile`` (a robot profile), None without one; a note on stderr
    if it was measured at another control period than ``--period``."""
    if args.profile is None:
        return None
    from ..hardware.profile import load_profile

    profile = load_profile(args.profile)
    note = profile.period_note(args.profile, args.period)
    if note is not None:
        print(note, file=sys.stderr)
    return profile.geometry


def _cmd_drive(args: argparse.Namespace) -> int:
    controller = Controller.load(args.controller)
    world = hardware_geometry(_profile_geometry(args), period_s=args.period)
    env = _make_env(args)
    try:
        # The teaching loop with the controller as the only commander.
        loop = TeachingLoop(
            env,
            controller.perception(world_geometry=world),
            Arbiter("policy"),
            policy=controller.commander(),
        )
        loop.reset()
        step = 0
        decisions: list[float] = []
        try:
            while args.steps is None or step < args.steps:
                done = loop.step()
                info = done.info_after
                step += 1
                decisions.append(done.decision_ms or 0.0)
                print(
                    f"step {step}: {info['command']} (board {info['board_state']}, "
                    f"rtt {info['link']['rtt_ms']:.0f} ms, decision {decisions[-1]:.1f} ms)",
                    flush=True,
                )
                if loop.terminated:
                    return _fail(f"stopped after {step} steps: {info['error']}")
        finally:
            if decisions:
                print(_decision_summary(decisions), flush=True)
        print(f"done: {step} steps; motors stopped")
        return EXIT_OK
    finally:
        env.close()


def _decision_summary(decisions_ms: Sequence[float]) -> str:
    """One line: the frame-to-command times of a drive (wall clock, this machine) against the
    decision budget of 5 ms."""
    ms = np.asarray(decisions_ms, dtype=np.float64)
    median, p99 = np.percentile(ms, [50, 99])
    return (
        f"frame to command over {len(ms)} steps: median {median:.1f} / p99 {p99:.1f} / max"
        f" {ms.max():.1f} ms (wall clock on this machine; the decision budget is 5 ms)"
    )


# --------------------------------------------------------------------------------------- demo
def _cmd_demo(args: argparse.Namespace) -> int:
    from ..hardware import teleop

    refuse_unsafe_output(args.out)  # before the camera and the link are opened
    refuse_undecodable(args.camera, "camera")  # recorded in the file's metadata
    profile = _profile_geometry(args)
    meta: dict[str, Any] = {"camera": args.camera, "control_period_s": args.period}
    if profile is not None:  # evolve teaches the map with the geometry it was recorded with
        meta["map_geometry"] = profile.to_dict()
    env = _make_env(args, between_steps="stop")
    try:
        obs, _ = env.reset()
        # The keyboard first: without a terminal nothing is created (a stub recording would
        # otherwise block the next run with "file exists").
        with (
            teleop.TerminalKeys() as keys,
            teleop.DemonstrationRecorder(
                args.out,
                bins=args.bins,
                library_only=args.library_only,
                metadata=meta,
                memory=memory_config({"kind": args.memory}),
                map_geometry=hardware_geometry(profile, period_s=args.period),
            ) as recorder,
        ):
            print(
                "w/up forward, a/left left, d/right right, space stop, p pause learning, q quit",
                flush=True,
            )
            sent = teleop.run_teleop(env, obs, keys, recorder)
        print(f"{sent} commands, {recorder.n_cases} cases recorded to {args.out}")
        if env.last_error is not None:  # the link or the camera failed: not a clean end
            return _fail(f"stopped after {sent} commands: {env.last_error}")
        return EXIT_OK
    finally:
        env.close()


# ---------------------------------------------------------------------------------- calibrate
def _cmd_calibrate(args: argparse.Namespace) -> int:
    from ..hardware.calibrate import calibrate, strip_start
    from ..hardware.profile import RobotProfile

    if args.sim and (args.camera or args.serial):
        return _fail("--camera and --serial are for the robot; --sim calibrates the simulator's")
    if not args.sim and not (args.camera and args.serial):
        return _fail("calibrate needs --camera URL and --serial URL (the robot) or --sim")
    if args.preset is not None and not args.sim:
        return _fail("--preset is for --sim (the robot's camera comes from --profile)")
    refuse_unsafe_output(args.out)  # before the robot moves
    known = _profile_geometry(args)
    options: dict[str, Any] | None = None
    if args.sim:
        from ..envs.presets import load_preset
        from ..envs.track_env import LfDTrackEnv

        preset = load_preset(args.preset or "paper")
        if preset.randomized:
            return _fail(
                f"preset '{preset.name}' draws a new world at every episode: calibrate in one"
                " without [randomization]"
            )
        camera = known.camera() if known is not None else preset.camera
        period_s = preset.rover.control_period_s  # the command's length, not its motion
        env: Any = LfDTrackEnv(track="training", preset=preset)
        # On the training track's straight: the simulator's strip, every run from its start.
        options = {"pose": strip_start(env.track)}
    else:
        camera = (known or hardware_geometry(period_s=args.period)).camera()
        period_s = args.period
        print(
            "place the robot at the start of a straight felt strip with at least"
            f" {args.runs * args.commands_per_run * 0.15:.1f} m ahead of it; it drives"
            f" {args.runs} runs of {args.commands_per_run} forward commands, left pivots and"
            " right pivots",
            flush=True,
        )
        if sys.stdin.isatty():
            input("press Enter to start (Ctrl-C to stop) ")
        env = _make_env(args)
    try:
        result = calibrate(
            env,
            camera,
            runs=args.runs,
            commands_per_run=args.commands_per_run,
            reset_options=options,
            seed=args.seed if args.sim else None,
            on_run=lambda line: print(line, flush=True),
        )
    finally:
        env.close()
    geometry = MapGeometry.from_camera(camera, step_m=result.step_m, pivot_deg=result.pivot_deg)
    RobotProfile(geometry, result, control_period_s=period_s).save(args.out)
    print(
        f"forward step {result.step_m:.4f} m per command (spread {100 * result.step_spread:.1f} %,"
        f" {len(result.forward_step_m)} runs); pivot {result.pivot_deg:.2f} deg per command"
        f" (spread {100 * result.pivot_spread:.1f} %, {len(result.pivot_samples_deg)} runs)"
    )
    print(f"robot profile written to {args.out}")
    return EXIT_OK


# ------------------------------------------------------------------------------------- parser
def _add_link_options(parser: argparse.ArgumentParser, required: bool = True) -> None:
    from ..hardware.wire import DEFAULT_BAUD  # not .link: the parser works without pyserial

    parser.add_argument(
        "--serial",
        required=required,
        metavar="URL",
        help="serial port or pyserial URL: /dev/rfcomm0, /dev/pts/N, socket://host:port",
    )
    parser.add_argument(
        "--baud", type=int, default=DEFAULT_BAUD, help="baud rate (default %(default)s)"
    )
    parser.add_argument(
        "--boot-wait",
        type=float,
        default=0.0,
        metavar="S",
        help="seconds to wait for the board's boot frame (firmware 1.1 and later also answer "
        "a version query; older firmware names its version only in the boot frame: a USB Arduino "
        "resets on open, try 2; reset other boards by hand during the wait)",
    )
    parser.add_argument(
        "--watchdog-ms", type=int, default=300, help="board motor watchdog [ms] (default 300)"
    )


def _add_profile_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--profile",
        metavar="FILE",
        default=None,
        help="robot profile written by `hardware calibrate`: the robot's measured forward step"
        " and pivot for the fresh_felt map (default: the paper preset's camera and rates at"
        " --period)",
    )


def _add_camera_options(parser: argparse.ArgumentParser, required: bool = True) -> None:
    parser.add_argument(
        "--camera",
        required=required,
        metavar="URL",
        help="phone stream (http://PHONE:8080/video), snapshot URL (…/shot.jpg) or video file",
    )
    parser.add_argument(
        "--period", type=float, default=0.4, metavar="S", help="control period [s] (default 0.4)"
    )


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``hardware`` with subcommands ``sim``, ``check``, ``calibrate``, ``drive``, ``demo``.

    Each leaf parser sets ``func`` (namespace → exit code).
    """
    hardware = subparsers.add_parser(
        "hardware",
        help="run on the real robot (or its firmware in simavr)",
        description="Real-robot backend: simulated board, link check, calibration, autonomous"
        " drive, demo.",
    )
    commands = hardware.add_subparsers(dest="hardware_command", metavar="COMMAND")
    commands.required = True

    sim = commands.add_parser(
        "sim",
        help="run the firmware in simavr and print its serial URL (until Ctrl-C/SIGTERM)",
        description="Build the rover firmware (hardware/firmware/) and run it in the AVR simulator"
        " simavr, with no robot attached. Prints a serial URL that `hardware check`, `drive` and"
        " `demo` accept as --serial; runs until Ctrl-C or SIGTERM, then stops the board and"
        " removes its run folder (see --keep-log).",
    )
    sim.add_argument(
        "--build-dir",
        default=None,
        help="build folder (default: a per-user cache folder, ~/.cache/lfd-track/simavr-HASH)",
    )
    sim.add_argument(
        "--keep-log",
        action="store_true",
        help="keep the run folder with the motor log after stopping (removed by default)",
    )
    sim.set_defaults(func=_guarded(_cmd_sim))

    check = commands.add_parser(
        "check",
        help="firmware version, round-trip time and safety self-test (no motion by default)",
        description="Open the serial link to the board (a real Romeo or `hardware sim`), report"
        " the firmware version from its boot frame, time --pings round trips and check that a"
        " ping never starts the motors and that e-stop latches. Nothing moves unless"
        " --lease-test is given.",
    )
    _add_link_options(check)
    check.add_argument("--pings", type=int, default=20, help="pings to time (default: 20)")
    check.add_argument(
        "--lease-test",
        action="store_true",
        help="also time the motor watchdog: runs the motors for one watchdog period, "
        "LIFT THE ROBOT so its tracks spin freely first",
    )
    check.set_defaults(func=_guarded(_cmd_check))

    calibrate = commands.add_parser(
        "calibrate",
        help="measure the robot's forward step and pivot from its camera; write a robot profile",
        description="Measure the robot's forward step [m] and pivot [deg] per command from its own"
        " camera frames: on a straight felt strip it drives --runs runs of --commands-per-run"
        " forward commands, left pivots and right pivots, each run from rest, and matches the"
        " bird's-eye views of the floor before and after each command. Writes a robot profile"
        " (--out) that `teach --backend hardware`, `hardware drive` and `hardware demo` read with"
        " --profile. With --sim it calibrates the simulated robot of --preset instead. A"
        " calibration that does not converge says why in one line, exits 1 and writes nothing.",
    )
    calibrate.add_argument("--out", required=True, metavar="FILE", help="robot profile to write")
    _add_camera_options(calibrate, required=False)
    _add_link_options(calibrate, required=False)
    calibrate.add_argument(
        "--sim", action="store_true", help="calibrate the simulated robot (no hardware)"
    )
    calibrate.add_argument(
        "--preset",
        default=None,
        metavar="NAME_OR_PATH",
        help="with --sim: the simulator's preset (default paper)",
    )
    calibrate.add_argument(
        "--seed", type=non_negative_int, default=0, help="with --sim: seed of the world (default 0)"
    )
    calibrate.add_argument(
        "--runs", type=positive_int, default=3, help="runs of each command (default 3)"
    )
    calibrate.add_argument(
        "--commands-per-run",
        type=positive_int,
        default=3,
        metavar="N",
        help="identical commands per run, from rest (default 3, as the simulator's rates are"
        " defined)",
    )
    calibrate.add_argument(
        "--profile",
        metavar="FILE",
        default=None,
        help="an earlier robot profile whose camera to keep (default: the --preset's camera with"
        " --sim, the paper preset's on the robot)",
    )
    calibrate.set_defaults(func=_guarded(_cmd_calibrate))

    drive = commands.add_parser(
        "drive",
        help="drive autonomously with a controller file",
        description="Drive the real robot with a saved controller: each phone-camera frame gives"
        " road values, the controller picks forward/left/right, and the command is sent as a"
        " lease the firmware drops after --watchdog-ms. Prints every step; stops the motors on"
        " Ctrl-C, link loss, a camera stall or any error.",
    )
    drive.add_argument("controller", metavar="CONTROLLER.json", help="controller file")
    _add_camera_options(drive)
    _add_link_options(drive)
    drive.add_argument("--steps", type=int, default=None, help="stop after N commands")
    _add_profile_option(drive)
    drive.set_defaults(func=_guarded(_cmd_drive))

    demo = commands.add_parser(
        "demo",
        help="drive with the keyboard and record a demonstration",
        description="Tele-operate the real robot from the keyboard (w/a/d or arrows: one command"
        " per press; space stops; p pauses road-library learning while the safe box is off the"
        " felt; q quits) and record every command with its road values to a .lfdemo file that"
        " `lfd-track evolve` reads.",
    )
    _add_camera_options(demo)
    _add_link_options(demo)
    demo.add_argument("--out", required=True, metavar="FILE", help="demonstration file (.lfdemo)")
    demo.add_argument("--bins", type=int, default=32, help="histogram bins (default: 32)")
    demo.add_argument(
        "--library-only",
        type=int,
        default=10,
        metavar="N",
        help="first N commands only build the road library (default 10)",
    )
    demo.add_argument(
        "--memory",
        choices=MEMORY_KINDS,
        default="none",
        help="memory inputs recorded with every case for the policy to read (see"
        " docs/learning-api.md; default none, the paper's 40 road values)",
    )
    _add_profile_option(demo)
    demo.set_defaults(func=_guarded(_cmd_demo))
    return hardware


def main(argv: Sequence[str] | None = None) -> int:
    """Stand-alone entry point: ``python -m lfd_track.cli.hardware hardware …``."""
    parser = argparse.ArgumentParser(prog="lfd-track")
    add_parser(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
