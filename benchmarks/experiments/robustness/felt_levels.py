"""Felt and carpet by the world's own levels: fixed road-value levels against levels read from the
road values the library gives in the world (``fresh_felt`` memory setting ``felt_levels``), and
whether the picture-steering teacher laps where the centreline teacher laps, on the same worlds.

Worlds: the paper world and ``--rooms`` rooms drawn from the ``randomized`` preset's ranges (all of
them: felt and carpet colours, light, exposure, noise, camera mount, slip), room k from
``numpy.random.default_rng(k)``, each kept for the whole measurement. Three parts, each world:

1. **Separation.** The centreline teacher drives a lap of the testing track while a careful
   perception learns its library (as in a demonstration); every frame, and a view from a pose
   beside the strip every fourth frame (0.3-0.5 m to one side, turned up to 60 deg: carpet
   with a strip's edge), is scored against the world's ground truth (which regions' floor is
   felt, from the camera's own model): the share of regions (at least 3/4 felt or at most 1/4)
   whose felt level is on the right side of 0.5 (the map's own felt test), the mean felt level
   of carpet regions and of felt regions, with the fixed levels and with the library levels as
   the perception had them at that frame.
2. **Teachers' laps.** Each teacher drives one lap of the testing track and of the procedural
   loops ``random:validation:0..2`` from an empty library, learning carefully as it goes; the
   first 10 commands are the centreline's (the protocol's library-only start), then the
   teacher's: ``centreline`` (pure pursuit on the known track), ``picture/fixed`` and
   ``picture/library`` (the fresh-felt rule at 20 deg on the chosen map, with either levels,
   its camera and motion the paper's), ``picture/library+world`` (library levels, the map's
   camera and motion the world's: ``geometry = "world"``, where this build has it); the
   chosen configuration's human (no reaction delay, no lapses).
3. **Demonstrations.** The demonstration protocol on the training track (the study's), each
   teacher, demonstration seed 0 in each world; and the world and seed of the study run that
   failed (``randomized``, study seed 0, repetition 0): finished or lost (over 600 commands;
   the study's limit is 1000, every demonstration that finished here took under 300).

Writes ``results/felt_levels.json`` and ``results/felt_levels.md``; 6-7 minutes on one core.

    .venv/bin/python benchmarks/experiments/robustness/felt_levels.py
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from lfd_track.benchmark.runner import repetition_seeds, repetition_streams
from lfd_track.core.camera_model import CameraModel
from lfd_track.core.frame import N_REGIONS, region_bounds
from lfd_track.demo.demonstrator import run_demonstration
from lfd_track.envs.presets import Preset, load_preset
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.errors import DemonstrationUnfinished
from lfd_track.policy.memory import CARPET_LEVEL, FELT_LEVEL
from lfd_track.policy.memory_config import FreshFeltConfig
from lfd_track.teaching.handwritten import FreshFeltRule, FreshFeltRuleConfig
from lfd_track.teaching.perception import Perception
from lfd_track.teaching.scripted import HumanConfig, ScriptedHuman
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.world.driver import CentrelineDriver

HERE = Path(__file__).resolve().parent
OUT = HERE / "results"
TRACKS = ("testing", "random:validation:0", "random:validation:1", "random:validation:2")
try:  # the map's camera and motion from the world it runs in, where this build has the setting
    from lfd_track.policy.map_geometry import MapGeometry
except ImportError:  # pragma: no cover - a build without it measures the levels alone
    MapGeometry = None  # type: ignore[assignment,misc]

#: The teachers: the centreline's pure pursuit, and the picture's fresh-felt rule on the chosen
#: map with fixed or library levels (the map's geometry the paper's, so the levels alone
#: change), and with library levels on a map whose camera and motion are the world's.
TEACHERS = ("centreline", "picture/fixed", "picture/library") + (
    ("picture/library+world",) if MapGeometry is not None else ()
)
#: Commands after which a demonstration counts as lost (the study's limit is 1000; every
#: demonstration that finished here took under 300).
LOST_AFTER = 600
#: The chosen configuration's human (benchmarks/experiments/goal/distilled.toml).
HUMAN = HumanConfig(
    steers_by="picture", reaction_delay_prob=0.0, lapse_prob=0.0, max_commands=LOST_AFTER
)
#: Samples per region edge for the ground truth (4 x 4 floor points per region).
_TRUTH_SAMPLES = 4
#: A region counts as felt (carpet) in the scores when at least (at most) this share is felt.
_FELT_SHARE, _CARPET_SHARE = 0.75, 0.25


def room(index: int) -> Preset:
    """Room ``index``: the ``randomized`` preset's ranges drawn once, kept (no more draws)."""
    randomized = load_preset("randomized")
    drawn = randomized.sample(np.random.default_rng(index))
    return dataclasses.replace(drawn, name=f"room{index}", randomization=())


def worlds(rooms: int) -> list[tuple[str, Preset | str]]:
    """The paper world and ``rooms`` rooms, by name."""
    return [("paper", "paper")] + [(f"room{k}", room(k)) for k in range(rooms)]


def _region_samples() -> np.ndarray:
    """(40 * 16, 2) pixels: a 4 x 4 grid of sample points inside each region, region by region."""
    grid = (np.arange(_TRUTH_SAMPLES) + 0.5) / _TRUTH_SAMPLES
    points = []
    for x0, y0, x1, y1 in (region_bounds(i) for i in range(N_REGIONS)):
        u, v = np.meshgrid(x0 + grid * (x1 - x0), y0 + grid * (y1 - y0))
        points.append(np.column_stack([u.ravel(), v.ravel()]))
    return np.concatenate(points)


_SAMPLES = _region_samples()


def felt_share(env: LfDTrackEnv, pose: np.ndarray) -> np.ndarray:
    """(40,) share of each region's floor that is felt, seen from ``pose`` (the world's truth)."""
    floor = CameraModel(env.preset.camera).floor_points(
        _SAMPLES, np.asarray(pose, dtype=np.float64)
    )
    on = env.track.on_felt(np.nan_to_num(floor, nan=1e6))
    return on.reshape(N_REGIONS, _TRUTH_SAMPLES**2).mean(axis=1)


def felt_level(values: np.ndarray, levels: tuple[float, float] | None) -> np.ndarray:
    """Felt levels of road values, as the map computes them."""
    carpet, felt = (CARPET_LEVEL, FELT_LEVEL) if levels is None else levels
    return np.clip((values - carpet) / (felt - carpet), 0.0, 1.0)


def separation(world: Preset | str) -> dict[str, Any]:
    """Part 1 in one world: scores of both levelings over on- and off-strip views."""
    env = LfDTrackEnv(track="testing", preset=world)
    obs, info = env.reset(seed=0)
    driver = CentrelineDriver(env.track)
    perception = Perception(RoadLibrary(), "careful", FreshFeltConfig(felt_levels="library"))
    assert perception.felt_levels is not None
    rng = np.random.default_rng(1)
    rows: list[tuple[np.ndarray, np.ndarray, tuple[float, float] | None]] = []
    for step in range(env.max_steps):
        pose = np.asarray(info["pose"])
        percept = perception.perceive(obs, info["safe_box_on_felt"])
        levels = perception.felt_levels.levels()
        rows.append((percept.values, felt_share(env, pose), levels))
        if step % 4 == 0:
            side = rng.choice([-1.0, 1.0])
            shift = rng.uniform(0.3, 0.5)
            turn = rng.uniform(-math.radians(60), math.radians(60))
            x, y, theta = pose
            beside = np.array(
                [
                    x - side * shift * math.sin(theta),
                    y + side * shift * math.cos(theta),
                    theta + turn,
                ]
            )
            frame = env.view_from(beside, rng)
            rows.append((perception.look(frame), felt_share(env, beside), levels))
        obs, _, terminated, truncated, info = env.step(int(driver.act(pose, info["progress_m"])))
        if terminated or truncated:
            break
    final = perception.felt_levels.levels()
    scores = {}
    for name in ("fixed", "library"):
        right = total = 0
        carpet_levels: list[np.ndarray] = []
        felt_levels: list[np.ndarray] = []
        for values, share, levels in rows:
            level = felt_level(values, None if name == "fixed" else levels)
            felt, carpet = share >= _FELT_SHARE, share <= _CARPET_SHARE
            right += int(((level >= 0.5) & felt).sum() + ((level < 0.5) & carpet).sum())
            total += int(felt.sum() + carpet.sum())
            carpet_levels.append(level[carpet])
            felt_levels.append(level[felt])
        scores[name] = {
            "right": right,
            "regions": total,
            "share_right": right / total,
            "carpet_mean_level": float(np.concatenate(carpet_levels).mean()),
            "felt_mean_level": float(np.concatenate(felt_levels).mean()),
        }
    return {"frames": len(rows), "final_levels": final, "scores": scores}


def teacher_memory(teacher: str) -> FreshFeltConfig:
    """The chosen map with the teacher's levels and geometry."""
    levels = "fixed" if teacher.endswith("fixed") else "library"
    if MapGeometry is None:
        return FreshFeltConfig(felt_levels=levels)
    geometry = "world" if teacher.endswith("world") else "paper"
    return FreshFeltConfig(felt_levels=levels, geometry=geometry)  # type: ignore[call-arg]


def teacher_lap(world: Preset | str, track: str, teacher: str) -> dict[str, Any]:
    """Part 2: one lap of ``track`` by ``teacher`` from an empty library."""
    env = LfDTrackEnv(track=track, preset=world)
    obs, info = env.reset(seed=0)
    memory = teacher_memory(teacher)
    extra = {}
    if teacher.endswith("world"):
        extra["geometry"] = MapGeometry.from_preset(env.preset)
    perception = Perception(RoadLibrary(), "careful", memory, **extra)
    person = ScriptedHuman(HUMAN, np.random.default_rng(0))
    rule = FreshFeltRule(FreshFeltRuleConfig(turn_deg=HUMAN.picture_turn_deg, memory=memory))
    driver = CentrelineDriver(env.track)
    off_felt = 0
    while True:
        pose = np.asarray(info["pose"])
        percept = perception.perceive(obs, info["safe_box_on_felt"])
        seen = None
        if teacher != "centreline" and info["step"] >= HUMAN.library_only_commands:
            seen = rule.act(percept.memory)
        command = person.decide(driver, pose, info["progress_m"], seen)
        perception.note(command)
        obs, _, terminated, truncated, info = env.step(int(command))
        off_felt += not any(info["on_felt"])
        if terminated or truncated:
            break
    return {
        "success": bool(info["success"]),
        "failure": info["failure"] or ("truncated" if not info["success"] else None),
        "commands": int(info["step"]),
        "lap_fraction": float(info["lap_fraction"]),
        "off_felt_commands": off_felt,
    }


def demonstration(world: Preset | str, seed: int, teacher: str) -> dict[str, Any]:
    """Part 3: the demonstration protocol on the training track; finished or lost."""
    steers = "centreline" if teacher == "centreline" else "picture"
    human = dataclasses.replace(HUMAN, steers_by=steers)
    with tempfile.TemporaryDirectory() as tmp:
        try:
            summary = run_demonstration(
                Path(tmp) / "demonstration.lfdemo",
                seed=seed,
                preset=world,
                human=human,
                memory=teacher_memory(teacher),
                fsync=False,
            )
        except DemonstrationUnfinished as lost:
            return {"finished": False, "why": str(lost)}
    return {
        "finished": True,
        "commands": summary.commands,
        "off_felt_frames": summary.off_felt_frames,
    }


def variants(index: int) -> dict[str, Preset]:
    """The controlled experiment's worlds for room ``index``: the room; its colours, light and
    sensor with the paper's camera and rover; the paper's with the room's camera and rover."""
    drawn, paper = room(index), load_preset("paper")
    return {
        "room": drawn,
        "room's colours and light, paper camera and rover": dataclasses.replace(
            drawn, camera=paper.camera, rover=paper.rover
        ),
        "paper colours and light, room's camera": dataclasses.replace(
            paper, name=f"room{index}-camera", camera=drawn.camera
        ),
        "paper colours and light, room's rover": dataclasses.replace(
            paper, name=f"room{index}-rover", rover=drawn.rover
        ),
    }


def controlled(rooms: list[int]) -> str:
    """Why the picture teacher with library levels still gets lost: the same laps and
    demonstration in each room split into its colours and light, its camera, its rover."""
    teachers = [t for t in TEACHERS if t.startswith("picture/library")]
    lines = [
        "# Controlled experiment: picture teacher, library levels",
        "",
        "| room | world | " + " | ".join(f"{t}: laps, demonstration" for t in teachers) + " |",
        "|---|---|" + "---|" * len(teachers),
    ]
    found: dict[str, Any] = {}
    for index in rooms:
        for name, world in variants(index).items():
            cells = []
            for teacher in teachers:
                laps = [teacher_lap(world, track, teacher)["success"] for track in TRACKS]
                demo = demonstration(world, 0, teacher)
                found[f"room{index}/{name}/{teacher}"] = {"laps": laps, "demonstration": demo}
                shown = demo["commands"] if demo["finished"] else "lost"
                cells.append(f"{sum(laps)}/{len(laps)}, {shown}")
            lines.append(f"| room{index} | {name} | " + " | ".join(cells) + " |")
            print(lines[-1], flush=True)
    OUT.mkdir(exist_ok=True)
    (OUT / "felt_levels_controlled.json").write_text(
        json.dumps(found, indent=1) + "\n", encoding="utf-8"
    )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rooms", type=int, default=5, help="rooms besides the paper world")
    parser.add_argument(
        "--controlled",
        type=int,
        nargs="+",
        metavar="ROOM",
        help="run the controlled experiment on these rooms instead (felt_levels_controlled.md)",
    )
    args = parser.parse_args()
    if args.controlled:
        table = controlled(args.controlled)
        (OUT / "felt_levels_controlled.md").write_text(table, encoding="utf-8")
        print(table)
        return
    t0 = time.perf_counter()
    study_world = repetition_streams(repetition_seeds(0, 1)[0])[0]
    results: dict[str, Any] = {"rooms": args.rooms, "worlds": {}}
    for name, world in worlds(args.rooms):
        row: dict[str, Any] = {"separation": separation(world), "laps": {}, "demonstration": {}}
        for track in TRACKS:
            row["laps"][track] = {t: teacher_lap(world, track, t) for t in TEACHERS}
        row["demonstration"] = {t: demonstration(world, 0, t) for t in TEACHERS}
        results["worlds"][name] = row
        print(name, f"{time.perf_counter() - t0:.0f} s", flush=True)
    results["study_failure"] = {
        "preset": "randomized",
        "demonstration_seed": study_world,
        "teachers": {t: demonstration("randomized", study_world, t) for t in TEACHERS},
    }
    results["wall_s"] = time.perf_counter() - t0
    OUT.mkdir(exist_ok=True)
    (OUT / "felt_levels.json").write_text(json.dumps(results, indent=1) + "\n", encoding="utf-8")
    table = report(results)
    (OUT / "felt_levels.md").write_text(table, encoding="utf-8")
    print(table)


def report(results: dict[str, Any]) -> str:
    """The three tables in Markdown."""
    lines = [
        "# Felt and carpet by the world's own levels",
        "",
        "## 1. Separation (regions whose felt level is on the right side of 0.5)",
        "",
        "| world | levels (library, end) | fixed: right | library: right"
        " | fixed: carpet / felt mean level | library: carpet / felt mean level |",
        "|---|---|---|---|---|---|",
    ]
    for name, row in results["worlds"].items():
        sep = row["separation"]
        fixed, library = sep["scores"]["fixed"], sep["scores"]["library"]
        levels = sep["final_levels"]
        shown = "–" if levels is None else f"{levels[0]:.2f} / {levels[1]:.2f}"
        lines.append(
            f"| {name} | {shown} | {fixed['share_right']:.1%} | {library['share_right']:.1%}"
            f" | {fixed['carpet_mean_level']:.3f} / {fixed['felt_mean_level']:.3f}"
            f" | {library['carpet_mean_level']:.3f} / {library['felt_mean_level']:.3f} |"
        )
    lines += [
        "",
        "## 2. Teachers' laps (testing track and random:validation:0-2; L lapped, - not, with why)",
        "",
        "| world | " + " | ".join(TEACHERS) + " |",
        "|---|" + "---|" * len(TEACHERS),
    ]
    totals = dict.fromkeys(TEACHERS, 0)
    n = 0
    for name, row in results["worlds"].items():
        cells = []
        for teacher in TEACHERS:
            marks = []
            for track in TRACKS:
                lap = row["laps"][track][teacher]
                marks.append("L" if lap["success"] else f"-({lap['failure']})")
                totals[teacher] += lap["success"]
            cells.append(" ".join(marks))
        n += len(TRACKS)
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines.append("| all | " + " | ".join(f"{totals[t]}/{n}" for t in TEACHERS) + " |")
    lines += [
        "",
        f"## 3. Demonstrations on the training track (commands; lost: over {LOST_AFTER})",
        "",
        "| world | " + " | ".join(TEACHERS) + " |",
        "|---|" + "---|" * len(TEACHERS),
    ]
    demos = {name: row["demonstration"] for name, row in results["worlds"].items()}
    failure = results["study_failure"]
    demos["randomized, study seed 0 rep 0"] = failure["teachers"]
    for name, row in demos.items():
        cells = [
            f"{d['commands']} ({d['off_felt_frames']} off felt)" if d["finished"] else "lost"
            for d in (row[t] for t in TEACHERS)
        ]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
