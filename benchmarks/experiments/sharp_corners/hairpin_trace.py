"""Part 59 of ``README.md``: what the laps lost past 155 degrees do at the hairpin.

Each repetition named (``--seed``, ``--repetition``) of a study like ``hairpins.toml`` is taught as
its study teaches it (the same room and streams), and its laps of the loops whose sharpest turn is
past ``--past`` degrees are driven again (the same worlds) with a record at every command: the
rover's pose against that turn's vertex, the command, the map's inputs and the track's progress.
Every failed lap is classed (:func:`classify`) and the classes tallied; with ``--rows`` each lap's
last rows near the vertex follow: how far before or past the vertex along the incoming strip,
how far to the turn's side of the incoming centreline and of the bisector between the two strips
(where the track's progress may count the rover on the outgoing strip), its heading turned toward
the corner, how far the progress lies below its most, the map's inputs and the command. Writes the
markdown and a ``.json`` record per lap beside it. With ``--loops-from FOLDER`` (part 69) the laps
are instead the procedural loop laps each repetition drove in that committed condition folder, in
the worlds its draw gave them (``--past 0``: all of them), so a round's rooms are driven again on
another map without the teacher's laps or the training track. A measurement on validation loops
and rooms only: nothing is chosen on it, and it drives no test loop.

    .venv/bin/python benchmarks/experiments/sharp_corners/hairpin_trace.py --study benchmarks/experiments/sharp_corners/hairpins.toml --seed 100 101 --repetition 0 1 2 3 4 5 6 7 8 9 --workers 2 --out benchmarks/experiments/sharp_corners/results/hairpin_trace/own.md
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import json
import math
import multiprocessing
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import corner_model  # noqa: E402
import cover_near  # noqa: E402
import edge_cover  # noqa: E402
import felt_window  # noqa: E402
import oracle_learner  # noqa: E402
import oracle_visited  # noqa: E402
import outer_cover  # noqa: E402
import spin_side  # noqa: E402
import start_prior  # noqa: E402
import tip_cover  # noqa: E402
import tip_latch  # noqa: E402
import track_branch  # noqa: E402
import true_senses  # noqa: E402
import turned_ahead  # noqa: E402
import way_back  # noqa: E402

from lfd_track.benchmark import runner  # noqa: E402
from lfd_track.benchmark.loops import loop_draws  # noqa: E402
from lfd_track.envs.track_env import LfDTrackEnv  # noqa: E402
from lfd_track.policy.memory import FreshFeltConfig, memory_for  # noqa: E402
from lfd_track.study.spec import load_study  # noqa: E402
from lfd_track.teaching import perception as perception_module  # noqa: E402
from lfd_track.world.track import load_track, vertex_turns_rad  # noqa: E402

#: the trace starts this far [m] of progress before the hairpin's vertex
BEFORE_M = 1.2
#: [m] a failed lap whose most progress lies further than this from its hairpin's vertex
#: failed elsewhere
NEAR_M = 1.5
#: pivots on a blank map within 0.3 m of the vertex counted as spinning there
SPIN_PIVOTS = 8
#: rows shown per lap: the last of those within 1.5 m of the vertex
SHOWN = 50


#: ``--taught-on-own``: the learner taught on the product's map, driven on the prototype's
TAUGHT_ON_OWN = False

#: ``--visited-from``, ``--felt-levels``, ``--map``: the condition's map's settings replaced by
#: these (none given: as they are)
MEMORY_SETTINGS: dict[str, Any] = {}

#: ``--loops-from``: a committed condition folder whose repetitions' procedural loop laps are
#: driven (in the worlds the repetition drew them in), not the study's ``test_tracks`` ("": those)
LOOPS_FROM = ""

#: ``--refit K`` (part 85): the repetition's fits drawn from the K-th other learning stream (its
#: starting weights), everything else as the study has it (0: the study's own stream)
REFIT = 0
#: a spawn key no stream of a repetition uses: the refits' streams are children of the
#: repetition's learning seed under it
REFIT_STREAM = 0x7265666974

#: ``--ensemble N`` (part 86): backprop's ensemble of the condition replaced by N networks (0: as
#: the study has it)
ENSEMBLE = 0


def committed_loop_worlds(
    folder: str, seed: int, repetition: int, trial_seed: int, split: str
) -> list[tuple[str, bool, str, int]]:
    """(track, reverse, direction, world seed) of the procedural loop laps repetition
    ``repetition`` of seed ``seed`` drove in the committed ``folder`` (its ``seed*/results.json``),
    each in the world its repetition's draw gave it (``loop_draws``), in the order driven."""
    if split == "test":
        raise SystemExit(f"--loops-from {folder}: its study draws test loops; this drives none")
    path = Path(folder) / f"seed{seed}" / "results.json"
    try:
        outcomes = json.loads(path.read_text(encoding="utf-8"))["outcomes"]
    except (OSError, ValueError, KeyError) as exc:
        raise SystemExit(f"{path}: not a study job's results ({exc})") from None
    names = list(
        dict.fromkeys(
            o["track"]
            for o in outcomes
            if o["repetition"] == repetition and o["track"].startswith("random:")
        )
    )
    worlds: dict[str, tuple[int, int]] = {}
    for name, pair in loop_draws(trial_seed, split):
        if name in names:
            worlds[name] = pair
            if len(worlds) == len(names):
                break
    if len(worlds) < len(names):
        raise SystemExit(f"{path}: repetition {repetition}'s loops are not this study's draw")
    return [
        (name, reverse, direction, worlds[name][index])
        for name in names
        for index, (reverse, direction) in enumerate(((False, "ccw"), (True, "cw")))
    ]


#: the prototype maps a flag teaches and drives on: (flag, the map's class, its page's words)
PROTOTYPE_MAPS: tuple[tuple[str, type, str], ...] = (
    ("--turned-ahead", turned_ahead.TurnedAheadMemory, "on `turned_ahead.py`'s map"),
    ("--spin-side", spin_side.SpinSideMemory, "on `spin_side.py`'s map"),
    ("--spin-centres", spin_side.SpinCentresMemory, "on `spin_side.py`'s `--centres` map"),
    ("--spin-band", spin_side.SpinBandMemory, "on `spin_side.py`'s `--spin-band` map"),
    ("--outer-cover", outer_cover.OuterCoverMemory, "on `outer_cover.py`'s map"),
    ("--edge-cover", edge_cover.EdgeCoverMemory, "on `edge_cover.py`'s map"),
    ("--strip-cover", edge_cover.StripCoverMemory, "on `edge_cover.py`'s `--strip-cover` map"),
    ("--turn-cover", edge_cover.TurnCoverMemory, "on `edge_cover.py`'s `--turn-cover` map"),
    ("--tip-cover", tip_cover.TipCoverMemory, "on `tip_cover.py`'s map"),
    ("--tip-edge-cover", tip_cover.TipEdgeCoverMemory, "on `tip_cover.py`'s `--edge` map"),
    ("--turn-tip", tip_cover.TurnTipMemory, "on `tip_cover.py`'s `--turn-tip` map"),
    ("--corner-model", corner_model.CornerModelMemory, "on `corner_model.py`'s map"),
    ("--start-prior", start_prior.StartPriorMemory, "on `start_prior.py`'s map"),
    ("--tip-latch", tip_latch.TipLatchMemory, "on `tip_latch.py`'s map"),
    (
        "--dead-end-points",
        tip_latch.DeadEndPointsMemory,
        "on `tip_latch.py`'s `--dead-end-points` map (part 13's test)",
    ),
    ("--true-felt", true_senses.TrueFeltMemory, "on the true felt at the regions (an oracle)"),
    ("--true-motion", true_senses.TrueMotionMemory, "moved by the true motion (an oracle)"),
    (
        "--true-senses",
        true_senses.TrueSensesMemory,
        "on the true felt, moved by the true motion (an oracle)",
    ),
    (
        "--centre-window",
        felt_window.CentreWindowMemory,
        "on `felt_window.py`'s map (felt read from each region's middle)",
    ),
    (
        "--hue-sat",
        felt_window.HueSatMemory,
        "on `felt_window.py`'s `--hue-sat` map (felt read from hue and saturation)",
    ),
)


#: the prototype scripts whose constants ``--set`` may change
SETTABLE = {
    "corner_model": corner_model,
    "edge_cover": edge_cover,
    "outer_cover": outer_cover,
    "start_prior": start_prior,
    "tip_cover": tip_cover,
    "tip_latch": tip_latch,
}


def set_constant(setting: str) -> None:
    """``--set MODULE.NAME=NUMBER``: a prototype script's existing numeric constant replaced."""
    name, _, value = setting.partition("=")
    module_name, _, constant = name.partition(".")
    module = SETTABLE.get(module_name)
    if module is None or not isinstance(getattr(module, constant, None), float):
        raise SystemExit(f"--set {setting}: no numeric constant {name} in {sorted(SETTABLE)}")
    setattr(module, constant, _number("--set", setting))


def map_numbers(settings: list[str]) -> dict[str, float]:
    """``--map NAME=NUMBER``: the map's numeric settings to replace, checked against the
    ``fresh_felt`` map's own (a bad one exits naming it)."""
    known = {
        field.name
        for field in dataclasses.fields(FreshFeltConfig)
        if field.type in (float, "float")
    }
    numbers: dict[str, float] = {}
    for setting in settings:
        name = setting.partition("=")[0]
        if name not in known:
            raise SystemExit(f"--map {setting}: no numeric map setting {name!r}")
        numbers[name] = _number("--map", setting)
    return numbers


def _number(flag: str, setting: str) -> float:
    """The number after the ``=`` of ``flag``'s ``setting`` (a bad one exits naming it)."""
    value = setting.partition("=")[2]
    try:
        return float(value)
    except ValueError:
        raise SystemExit(f"{flag} {setting}: {value!r} is not a number") from None


def _dest(flag: str) -> str:
    """The attribute argparse gives ``flag``."""
    return flag[2:].replace("-", "_")


def measure_parser(description: str) -> argparse.ArgumentParser:
    """The command line of a script that measures on some repetitions' hairpin laps:
    ``--study``, ``--seed``, ``--repetition`` and ``--out`` (the markdown page)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--study", required=True)
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--repetition", type=int, nargs="+", required=True)
    parser.add_argument("--out", required=True)
    return parser


def drive_repetitions(study_file: str, seed: int, repetitions: list[int]) -> list[dict[str, Any]]:
    """Teach and drive ``repetitions`` of ``seed`` in this process (:func:`trace_repetition`, laps
    past 155°, no rows); the laps' records."""
    laps: list[dict[str, Any]] = []
    for repetition in repetitions:
        laps += trace_repetition((study_file, seed, repetition, 155.0, False))[1]
    return laps


def write_page(out: str, lines: list[str]) -> None:
    """Write a measurement's markdown ``lines`` to ``out`` (its folder made) and print them."""
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    Path(out).write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


def hairpin(track: Any) -> tuple[np.ndarray, np.ndarray, float, float]:
    """(vertex (2,), incoming unit direction (2,), signed turn [rad], progress at the vertex [m])
    of ``track``'s sharpest corner, in its driving order."""
    vertices = np.asarray(track.vertices, dtype=np.float64)
    turns = vertex_turns_rad(vertices, True)
    k = int(np.argmax(np.abs(turns)))
    before = vertices[k - 1]
    a_in = vertices[k] - before
    a_in = a_in / np.linalg.norm(a_in)
    lengths = np.linalg.norm(np.diff(np.vstack([vertices, vertices[:1]]), axis=0), axis=1)
    return vertices[k], a_in, float(turns[k]), float(lengths[:k].sum())


def trace_lap(env: LfDTrackEnv, controller: Any, world: int) -> tuple[dict[str, Any], list[dict]]:
    """Drive one lap; the last info and a row per command."""
    rows: list[dict[str, Any]] = []

    def seen(step: Any) -> None:
        info = step.info_after or step.moment.info
        inputs = step.moment.inputs
        rows.append(
            {
                "pose": tuple(step.moment.info["pose"]),
                "progress": float(step.moment.info["progress_m"]),
                "command": None if step.command is None else int(step.command),
                "inputs": None if inputs is None else [float(v) for v in inputs[-4:]],
                "after": float(info.get("progress_m", math.nan)),
            }
        )

    info, _, _ = runner.run_trial(env, controller, seed=world, on_loop_step=seen)
    return info, rows


def blank_pivots(rows: list[dict[str, Any]], vertex: np.ndarray) -> int:
    """The pivots a lap made within 0.3 m of the hairpin's vertex on a blank map (amount 0)."""
    return sum(
        1
        for row in rows
        if row["command"] in (1, 2)
        and row["inputs"] is not None
        and row["inputs"][1] == 0.0
        and float(np.hypot(row["pose"][0] - vertex[0], row["pose"][1] - vertex[1])) < 0.3
    )


def first_blank_pivot(
    rows: list[dict[str, Any]], vertex: np.ndarray, turn: float
) -> tuple[str, str]:
    """Which way the lap's first pivot on a blank map within 0.3 m of the vertex turned, and
    which side the branch side input named there: each ``toward`` (the corner's way), ``away``
    or, for the branch side, ``none`` (0.5); ``-`` without such a pivot."""
    for row in rows:
        if (
            row["command"] in (1, 2)
            and row["inputs"] is not None
            and row["inputs"][1] == 0.0
            and float(np.hypot(row["pose"][0] - vertex[0], row["pose"][1] - vertex[1])) < 0.3
        ):
            left = turn > 0.0
            pivot = "toward" if (row["command"] == 1) == left else "away"
            branch = row["inputs"][3]
            named = "none" if branch == 0.5 else ("toward" if (branch > 0.5) == left else "away")
            return pivot, named
    return "-", "-"


def by_pivot(laps: list[dict[str, Any]]) -> dict[tuple[str, str], list[dict[str, Any]]]:
    """The laps by (first blank pivot at the vertex, the side the branch side named there)."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = collections.defaultdict(list)
    for lap in laps:
        groups[lap["first_pivot"], lap["branch_named"]].append(lap)
    return dict(groups)


def classify(rows: list[dict[str, Any]], s_vertex: float, length: float) -> dict[str, Any]:
    """How a failed lap ended against its hairpin, from the track's progress: ``elsewhere`` (its
    most progress more than :data:`NEAR_M` from the vertex's, along the loop), ``counted round``
    (its progress had passed the vertex's: the track counted the rover on the outgoing strip,
    and then fell back) or ``not round`` (it had not: turned back on the incoming side)."""
    best = max(max(row["progress"], row["after"]) for row in rows)
    # the lap's copy of the vertex nearest its most progress
    gap = best - s_vertex
    gap -= length * round(gap / length)
    if abs(gap) > NEAR_M:
        kind = "elsewhere"
    else:
        kind = "counted round" if gap >= 0.0 else "not round"
    return {"kind": kind, "past_vertex_m": gap}


def refit_seed(ga_seed: int, refit: int) -> int:
    """The learning seed of ``--refit refit``: a 62-bit seed drawn from the repetition's own
    learning seed and :data:`REFIT_STREAM`, so each refit's starting weights are other than the
    study's and than every other refit's, and the same on every run."""
    rng = np.random.default_rng([ga_seed, REFIT_STREAM, refit])
    return int(rng.integers(0, 2**62))


def trace_repetition(job: tuple[str, int, int, float, bool]) -> tuple[list[str], list[dict]]:
    """Teach repetition ``repetition`` of seed ``seed`` of ``study_file`` and drive its hairpin
    laps past ``past`` degrees (with ``show``, the traces' rows); the markdown lines and a record
    per lap."""
    study_file, seed, repetition, past, show = job
    study = load_study(study_file)
    config = dataclasses.replace(study.conditions[0].config, repetitions=study.repetitions)
    config = dataclasses.replace(config, seed=seed)
    if MEMORY_SETTINGS:
        memory = dataclasses.replace(config.memory, **MEMORY_SETTINGS)
        config = dataclasses.replace(config, memory=memory)
    rep_seed = runner.repetition_seeds(seed, study.repetitions)[repetition]
    demo_seed, ga_seed, trial_seed = runner.repetition_streams(rep_seed)
    if REFIT:
        ga_seed = refit_seed(ga_seed, REFIT)
    if ENSEMBLE:
        config = dataclasses.replace(config, bc=dataclasses.replace(config.bc, ensemble=ENSEMBLE))
    preset = runner.repetition_preset(config, rep_seed)
    driving_maps = perception_module.memory_for
    if TAUGHT_ON_OWN:  # the demonstration records the product's map; the prototype drives
        perception_module.memory_for = memory_for
    try:
        with tempfile.TemporaryDirectory() as tmp:
            learned = runner.learn_repetition(
                config, Path(tmp), demo_seed=demo_seed, ga_seed=ga_seed, preset=preset
            )
    finally:
        perception_module.memory_for = driving_maps
    controller = learned.controller
    letter = {0: "F", 1: "L", 2: "R"}
    lines: list[str] = []
    laps: list[dict] = []
    trials = runner.trial_worlds(trial_seed, config.test_tracks)
    if LOOPS_FROM:
        trials = committed_loop_worlds(
            LOOPS_FROM, seed, repetition, trial_seed, config.random_split
        )
    for track_name, reverse, direction, world in trials:
        if not track_name.startswith("random"):
            continue
        if math.degrees(abs(hairpin(load_track(track_name))[2])) <= past:
            continue
        env = LfDTrackEnv(track=track_name, reverse=reverse, preset=preset)
        info, rows = trace_lap(env, controller, world)
        # the env's track: its vertices in driving order from the lap's start, where its
        # progress counts from
        track = env.track
        vertex, a_in, turn, s_vertex = hairpin(track)
        env.close()
        lap = {"seed": seed, "repetition": repetition, "track": track_name}
        lap |= {"direction": direction, "success": bool(info["success"])}
        lap["blank_pivots"] = blank_pivots(rows, vertex)
        lap["first_pivot"], lap["branch_named"] = first_blank_pivot(rows, vertex, turn)
        if not info["success"]:
            lap |= classify(rows, s_vertex, track.length_m)
        laps.append(lap)
        if not show:
            continue
        sign = 1.0 if turn > 0 else -1.0
        normal = sign * np.array([-a_in[1], a_in[0]])
        half = (math.pi - abs(turn)) / 2.0  # the bisector's angle off the incoming line
        outcome = "lapped" if info["success"] else f"failed: {info['failure'] or 'timeout'}"
        if not info["success"]:
            outcome += f" ({lap['kind']})"
        lines += [
            f"## {track_name} {direction} (seed {seed}, repetition {repetition}): turn"
            f" {math.degrees(turn):+.1f} deg, width {track.width_m:.3f} m, {outcome}",
            "",
            "| step | along | side | bis | turned | drop | bearing | amount | distance | branch"
            " | command |",
            "|---|---|---|---|---|---|---|---|---|---|---|",
        ]
        best = -math.inf
        shown: list[str] = []
        for k, row in enumerate(rows):
            x, y, theta = row["pose"]
            rel = np.array([x, y]) - vertex
            along = float(rel @ a_in)
            side = float(rel @ normal)
            # distance to the turn's side of the bisector through the vertex
            bis = side * math.cos(half) + along * math.sin(half)
            heading = np.array([math.cos(theta), math.sin(theta)])
            turned = math.degrees(math.atan2(float(heading @ normal), float(heading @ a_in)))
            best = max(best, row["progress"])
            if along < -BEFORE_M or np.linalg.norm(rel) > 1.5:
                continue
            inputs = row["inputs"] or [math.nan] * 4
            command = "-" if row["command"] is None else letter[row["command"]]
            shown.append(
                f"| {k} | {along:+.2f} | {side:+.2f} | {bis:+.2f} | {turned:+.0f} |"
                f" {best - row['progress']:.2f} | {inputs[0]:.2f} | {inputs[1]:.2f} |"
                f" {inputs[2]:.2f} | {inputs[3]:.2f} | {command} |"
            )
        # the last visit to the vertex decides the lap: its last SHOWN rows
        lines += shown[-SHOWN:]
        x, y, _ = rows[-1]["pose"]
        end = np.array([x, y]) - vertex
        lines += [
            "",
            f"{len(rows)} commands; the lap ends {float(np.linalg.norm(end)):.2f} m from the"
            f" vertex, {best - rows[-1]['after']:.2f} m of progress below its most.",
            "",
        ]
    return lines, laps


def main() -> None:
    global TAUGHT_ON_OWN, SHOWN, LOOPS_FROM, REFIT, ENSEMBLE
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", required=True)
    parser.add_argument("--seed", type=int, nargs="+", required=True)
    parser.add_argument("--repetition", type=int, nargs="+", required=True)
    parser.add_argument("--past", type=float, default=155.0, help="[deg] sharpest turn past")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--rows", action="store_true", help="each lap's trace after the tally")
    parser.add_argument(
        "--shown", type=int, default=SHOWN, help="with --rows: the last N rows near the vertex"
    )
    parser.add_argument("--out", required=True, help="the markdown trace to write")
    parser.add_argument(
        "--loops-from",
        default="",
        metavar="FOLDER",
        help="drive the procedural loop laps each repetition drove in this committed condition"
        " folder (seed*/results.json), not the study's test_tracks",
    )
    parser.add_argument(
        "--way-back", action="store_true", help="taught and driven on way_back.py's map"
    )
    parser.add_argument("--side-m", type=float, help="with --way-back: its SIDE_M [m]")
    parser.add_argument(
        "--oracle", action="store_true", help="taught and driven on part 12's oracle map (cover)"
    )
    parser.add_argument(
        "--spin-hold", type=float, metavar="DEG", help="with --spin-side: its HOLD_DEG [deg]"
    )
    parser.add_argument(
        "--visited-from", default="", help="the condition's map's visited_from replaced by this"
    )
    parser.add_argument(
        "--felt-levels",
        default="",
        choices=("", "fixed", "library"),
        help="the condition's map's felt_levels replaced by this",
    )
    parser.add_argument(
        "--map",
        action="append",
        default=[],
        metavar="NAME=NUMBER",
        help="the condition's map's numeric setting NAME replaced by NUMBER (repeatable)",
    )
    parser.add_argument(
        "--cover-to", type=float, metavar="M", help="with --oracle: cover_near.py's cover, to M"
    )
    parser.add_argument(
        "--cover-leg",
        choices=("incoming", "incoming-outer", "incoming-inner", "others"),
        help="with --oracle: cover_near.py's cover only on (or off) the hairpin's incoming leg",
    )
    parser.add_argument(
        "--edge-mask",
        choices=("leg", "outer", "leg-outer"),
        help="with --edge-cover-track-side: its cover cut by the track (edge_cover.EDGE_MASK)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="MODULE.NAME=NUMBER",
        help="set a prototype script's constant, e.g. edge_cover.GAP_M=0.2 (repeatable)",
    )
    parser.add_argument(
        "--taught-on-own",
        action="store_true",
        help="the learner taught on the product's own map, driven on the map the flags name",
    )
    parser.add_argument(
        "--in-spins",
        action="store_true",
        help="with --oracle --cover-leg: the cover only in outer_cover.py's spins (edge_cover.py)",
    )
    parser.add_argument(
        "--track-branch",
        action="store_true",
        help="taught and driven on track_branch.py's map (the track's side as the branch side)",
    )
    parser.add_argument(
        "--edge-cover-track-side",
        action="store_true",
        help="taught and driven on edge_cover.py's map with the track's turn side (an oracle)",
    )
    parser.add_argument(
        "--cover-start",
        type=float,
        metavar="M",
        help="with --oracle: the cover only behind the lap's start, while the progress is below M",
    )
    parser.add_argument("--sides", choices=("branch", "both"), help="with --way-back: its SIDES")
    parser.add_argument(
        "--refit",
        type=int,
        default=0,
        metavar="K",
        help="the fits drawn from the K-th other learning stream (their starting weights)",
    )
    parser.add_argument(
        "--ensemble", type=int, default=0, metavar="N", help="backprop's ensemble replaced by N"
    )
    for flag, _, phrase in PROTOTYPE_MAPS:
        parser.add_argument(flag, action="store_true", help=f"taught and driven {phrase}")
    args = parser.parse_args()
    if args.in_spins and not (args.oracle and (args.cover_leg or args.cover_to is not None)):
        parser.error("--in-spins needs --oracle with --cover-leg or --cover-to")
    if args.edge_mask and not args.edge_cover_track_side:
        parser.error("--edge-mask needs --edge-cover-track-side")
    if args.refit < 0 or args.ensemble < 0:
        parser.error("--refit and --ensemble take 0 (as the study has it) or more")
    if args.way_back:
        oracle_visited.maps_made_as(way_back.WayBackMemory)
        if args.side_m is not None:
            way_back.SIDE_M = args.side_m
        if args.sides is not None:
            way_back.SIDES = args.sides
    if args.oracle:
        oracle_learner.use_oracle("cover", 0.3)
        if args.cover_to is not None or args.cover_leg or args.cover_start:
            cover_near.COVER_TO_M = math.inf if args.cover_to is None else args.cover_to
            cover_near.LEG = args.cover_leg or ""
            cover_near.START_M = args.cover_start or 0.0
            oracle_visited.maps_made_as(cover_near.CoverNearMemory)
            if args.in_spins:
                oracle_visited.maps_made_as(edge_cover.SpinOracleMemory)
    settings = {"visited_from": args.visited_from, "felt_levels": args.felt_levels}
    MEMORY_SETTINGS.update({name: value for name, value in settings.items() if value})
    MEMORY_SETTINGS.update(map_numbers(args.map))
    TAUGHT_ON_OWN = args.taught_on_own
    SHOWN = args.shown
    LOOPS_FROM = args.loops_from
    REFIT, ENSEMBLE = args.refit, args.ensemble
    if args.track_branch:
        track_branch.use_track_branch()
    for setting in args.set:
        set_constant(setting)
    if args.edge_cover_track_side:
        track_branch.use_track_branch(edge_cover.TrackSideEdgeCoverMemory)
        edge_cover.EDGE_MASK = args.edge_mask or ""
    for flag, memory_class, _ in PROTOTYPE_MAPS:
        if getattr(args, _dest(flag)):
            oracle_visited.maps_made_as(memory_class)
            prepare = getattr(memory_class, "prepare", None)  # e.g. the true pose kept
            if prepare is not None:
                prepare()
    if args.spin_hold is not None:
        spin_side.HOLD_DEG = args.spin_hold
    jobs = [
        (args.study, seed, repetition, args.past, args.rows)
        for seed in args.seed
        for repetition in args.repetition
    ]
    with multiprocessing.get_context("fork").Pool(args.workers) as pool:
        done = pool.map(trace_repetition, jobs, chunksize=1)
    laps = [lap for _, some in done for lap in some]
    failed = [lap for lap in laps if not lap["success"]]
    table = collections.Counter((lap["kind"], lap["blank_pivots"] >= SPIN_PIVOTS) for lap in failed)
    lines = [
        f"# Hairpin laps of `{Path(args.study).name}` past {args.past:g} degrees",
        "",
        f"Seeds {args.seed}, repetitions {args.repetition}"
        + (", on `way_back.py`'s map" if args.way_back else "")
        + "".join(f", {phrase}" for flag, _, phrase in PROTOTYPE_MAPS if getattr(args, _dest(flag)))
        + (", on `track_branch.py`'s map" if args.track_branch else "")
        + (
            ", on `edge_cover.py`'s map with the track's turn side (an oracle)"
            + (f", its cover cut by the track (`{args.edge_mask}`)" if args.edge_mask else "")
            if args.edge_cover_track_side
            else ""
        )
        + (f", with `visited_from = {args.visited_from!r}`" if args.visited_from else "")
        + (f", with `felt_levels = {args.felt_levels!r}`" if args.felt_levels else "")
        + "".join(f", with `{setting}`" for setting in args.map)
        + (", on part 12's oracle map (`--combine cover --cover-from 0.3`)" if args.oracle else "")
        + (f", its cover cut at {args.cover_to:g} m behind" if args.cover_to is not None else "")
        + (
            f", its cover only behind the lap's start while the progress is below"
            f" {args.cover_start:g} m"
            if args.cover_start
            else ""
        )
        + (
            ", its cover only "
            + {
                "incoming": "on the hairpin's incoming leg",
                "others": "off the hairpin's incoming leg",
                "incoming-outer": "on the hairpin's incoming leg, outside its centreline",
                "incoming-inner": "on the hairpin's incoming leg, on its centreline's turn side",
            }[args.cover_leg]
            if args.cover_leg
            else ""
        )
        + (", and only in `outer_cover.py`'s spins (`edge_cover.py`)" if args.in_spins else "")
        + "".join(f", `{setting}`" for setting in args.set)
        + (", taught on the product's own map" if args.taught_on_own else "")
        + (f", the fits from learning stream {args.refit} of the refits" if args.refit else "")
        + (f", an ensemble of {args.ensemble} networks" if args.ensemble else "")
        + f": {sum(lap['success'] for lap in laps)} of {len(laps)} laps lapped. How the"
        f" {len(failed)} others ended (`hairpin_trace.py`'s `classify`), and whether the rover"
        f" had pivoted {SPIN_PIVOTS} times or more (a full turn is 16) within 0.3 m of the"
        " vertex on a blank map before:",
        "",
        f"| how the lap ended | {SPIN_PIVOTS}+ blank pivots at the vertex | fewer | all |",
        "|---|---|---|---|",
        *(
            f"| {kind} | {table[kind, True]} | {table[kind, False]} |"
            f" {table[kind, True] + table[kind, False]} |"
            for kind in ("not round", "counted round", "elsewhere")
        ),
        "",
        f"Of the {len(laps) - len(failed)} laps lapped,"
        f" {sum(1 for lap in laps if lap['success'] and lap['blank_pivots'] >= SPIN_PIVOTS)}"
        f" had pivoted {SPIN_PIVOTS} times or more there on a blank map too.",
        "",
        "The first pivot each lap made on a blank map within 0.3 m of the vertex: the corner's"
        " way (`toward`) or not (`away`), and the side the branch side input named there"
        " (`none`: 0.5); `-`: no such pivot.",
        "",
        "| first blank pivot | branch side named | laps | lapped |",
        "|---|---|---|---|",
        *(
            f"| {pivot} | {named} | {len(some)} | {sum(lap['success'] for lap in some)} |"
            for (pivot, named), some in sorted(by_pivot(laps).items())
        ),
        "",
        "`not round`: the track never counted the rover past the vertex (it turned back on the"
        " incoming side); `counted round`: the track had counted it on the outgoing strip, and"
        f" its progress then fell back; `elsewhere`: its most progress lay more than {NEAR_M:g} m"
        " from the vertex's.",
        "",
        "Columns of the traces: `along` is the rover's axle before (-) or past (+) the vertex"
        " along the incoming strip [m]; `side` its offset to the turn's side of the incoming"
        " centreline [m]; `bis` its offset to the turn's side of the bisector between the strips"
        " (positive: the outgoing strip's half, where the track's progress may count it on that"
        " strip) [m]; `turned` its heading turned toward the corner from the incoming direction"
        " [deg]; `drop` how far the progress lies below its most so far [m]; the map's four"
        " inputs (bearing, amount, distance, branch side); the command.",
        "",
    ]
    for some, _ in done:
        lines += some
    Path(args.out).write_text("\n".join(lines) + "\n", encoding="utf-8")
    Path(args.out).with_suffix(".json").write_text(json.dumps(laps, indent=1), encoding="utf-8")
    print("\n".join(lines[:16]))


if __name__ == "__main__":
    main()
