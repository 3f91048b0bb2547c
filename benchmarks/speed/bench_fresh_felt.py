"""The ``fresh_felt`` map's update per step on one core: ``see()`` + ``inputs()`` on recorded
episodes, for this checkout and optionally an older one (``--baseline``), in the same run.

The episodes are recorded first (not timed): ``LfDTrack-v0`` with the paper preset on the training
track, the testing track and the procedural loop ``random:test:3``, each way round, driven by the
teacher (the centreline-following scripted human) with one command in twelve drawn at random so
that the rover also wobbles off the strip; the road values come from a perception learning the
road library as it goes (careful rule). Each side then replays the same road values and commands
through its own :class:`~lfd_track.policy.memory.FreshFeltMemory` (``reset()`` at each episode's
start, ``see()`` and ``inputs()`` timed at each step, ``note()`` of the executed command after
it, untimed) in a fresh process with its own source tree first on ``sys.path``, so each measures
the code it has. Maps: the goal's chosen one (the shipped defaults), round 16's (no picture
links) and the plain map (every option off). The sides alternate over ``--rounds``; the figures
are the process's CPU microseconds per step (min and median over rounds) and the ratio of the
medians (baseline over this checkout). The two sides' inputs are compared step by step too.

Baseline: ``git worktree add --detach /tmp/fresh_felt_base <commit>`` (or ``git archive <commit>
lfd_track | tar -x -C DIR``).

Run: ``.venv/bin/python benchmarks/speed/bench_fresh_felt.py [--baseline DIR --baseline-label
COMMIT] [--rounds 5] [--steps 300]`` — prints a table and writes ``benchmarks/speed/results/fresh_felt.json``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import gymnasium as gym
import numpy as np
from single_thread import load_average, pin_one_thread, run_facts

import lfd_track  # noqa: F401  (registers LfDTrack-v0)
from lfd_track.benchmark.loops import TEACHER
from lfd_track.teaching.perception import Perception
from lfd_track.teaching.scripted import ScriptedHuman
from lfd_track.utils.atomic import atomic_write_text
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.world.driver import CentrelineDriver

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
RESULTS = HERE / "results" / "fresh_felt.json"
TRACKS = ("training", "testing", "random:test:3")
#: The maps timed: the goal's chosen map (the defaults), round 16's and the plain map.
MAPS = {
    "chosen": {},
    "round16": {"strip_picture_links": False},
    "plain": {
        "blank_bearing": "centre",
        "bearing_range_deg": 180.0,
        "strip_link_m": 0.0,
        "strip_picture_links": False,
        "blank_reach_m": 0.0,
        "blank_distance": "blank_reach",
        "visited_fade_m": 0.0,
    },
}
RANDOM_COMMAND = 1 / 12

# Run in a fresh interpreter with the tree first on sys.path: replays the recorded episodes
# through each map, prints CPU microseconds per step and the inputs of every step.
_CHILD = """
import json, sys, time
import numpy as np
tree, episodes_file, maps = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
sys.path[:0] = [tree, tree + "/benchmarks/speed"]
from single_thread import pin_one_thread
pin_one_thread()
from lfd_track.policy import memory as module
from lfd_track.policy.memory import FreshFeltConfig, FreshFeltMemory
data = np.load(episodes_file)
values, commands, starts = data["values"], data["commands"].tolist(), set(data["starts"].tolist())
out = {}
for name, settings in maps.items():
    memory = FreshFeltMemory(FreshFeltConfig(**settings))
    inputs = np.zeros((len(commands), 3))
    spent = 0
    for step, command in enumerate(commands):
        if step in starts:
            memory.reset()
        begin = time.process_time_ns()
        memory.see(values[step])
        inputs[step] = memory.inputs()
        spent += time.process_time_ns() - begin
        memory.note(command)
    out[name] = {"us_per_step": spent / 1e3 / len(commands), "inputs": inputs.tolist()}
print(json.dumps({"module": module.__file__, "maps": out}))
"""


def record_episodes(steps: int, seed: int) -> dict[str, np.ndarray]:
    """Road values (S, 40), commands (S,) and episode starts of at least ``steps`` steps per
    track (episodes each way round, alternately)."""
    rng = np.random.default_rng(seed)
    values, commands, starts = [], [], []
    for track in TRACKS:
        perception = Perception(RoadLibrary(), "careful", None)
        recorded, episode = 0, 0
        while recorded < steps:
            env = gym.make("LfDTrack-v0", track=track, preset="paper", reverse=bool(episode % 2))
            frame, info = env.reset(seed=seed + episode)
            driver = CentrelineDriver(env.unwrapped.track, TEACHER.driver)
            person = ScriptedHuman(TEACHER, rng)
            starts.append(len(commands))
            episode += 1
            done = False
            while not done:
                percept = perception.perceive(frame, info.get("safe_box_on_felt"))
                command = int(person.decide(driver, np.asarray(info["pose"]), info["progress_m"]))
                if rng.random() < RANDOM_COMMAND:
                    command = int(rng.integers(3))
                values.append(np.asarray(percept.values, dtype=np.float64))
                commands.append(command)
                frame, _, terminated, truncated, info = env.step(command)
                done = terminated or truncated
                recorded += 1
            env.close()
    return {
        "values": np.array(values),
        "commands": np.array(commands, dtype=np.int64),
        "starts": np.array(starts, dtype=np.int64),
    }


def replay(tree: Path, episodes: Path) -> dict[str, dict]:
    """One side's replay in a fresh process: the memory module's file, and per map the CPU µs
    per step and every step's inputs."""
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD, str(tree), str(episodes), json.dumps(MAPS)],
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(proc.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, help="source tree of the code to compare with")
    parser.add_argument(
        "--baseline-label", default="", help="what the baseline tree is (e.g. its commit)"
    )
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--steps", type=int, default=300, help="steps recorded per track")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args()
    if args.rounds < 1 or args.steps < 1:
        parser.error("--rounds and --steps must be >= 1")
    if args.baseline is not None and not (args.baseline / "lfd_track").is_dir():
        parser.error(f"--baseline {args.baseline} holds no lfd_track package")
    pin_one_thread()
    before = load_average()
    episodes = record_episodes(args.steps, args.seed)
    n_steps = len(episodes["commands"])
    print(f"recorded {n_steps} steps in {len(episodes['starts'])} episodes", flush=True)
    sides = {"this": REPO} | ({"baseline": args.baseline} if args.baseline else {})
    timings: dict[str, dict[str, list[float]]] = {side: {m: [] for m in MAPS} for side in sides}
    inputs: dict[str, dict[str, np.ndarray]] = {}
    modules: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "episodes.npz"
        np.savez(path, **episodes)
        for index in range(args.rounds):
            order = list(sides) if index % 2 == 0 else list(sides)[::-1]
            for side in order:
                result = replay(sides[side], path)
                modules[side] = result["module"]
                result = result["maps"]
                for name, row in result.items():
                    timings[side][name].append(row["us_per_step"])
                    inputs.setdefault(side, {})[name] = np.array(row["inputs"])
                print(side, {m: round(r["us_per_step"]) for m, r in result.items()}, flush=True)
    rows = []
    for name in MAPS:
        row: dict[str, object] = {"map": name}
        for side in sides:
            row[f"{side}_us_min"] = round(min(timings[side][name]), 1)
            row[f"{side}_us_median"] = round(statistics.median(timings[side][name]), 1)
        if "baseline" in sides:
            base, this = (statistics.median(timings[s][name]) for s in ("baseline", "this"))
            row["speedup"] = round(base / this, 2)
            gap = np.abs(inputs["baseline"][name] - inputs["this"][name])
            row["max_input_difference"] = float(gap.max())
        rows.append(row)
        print(json.dumps(row))
    out = {
        "benchmark": "fresh_felt_map_per_step",
        "what": "FreshFeltMemory.see() + inputs() per step, CPU microseconds, one thread",
        "episodes": f"{n_steps} steps of {', '.join(TRACKS)} (teacher + 1/12 random commands)",
        "baseline": (
            {"tree": str(args.baseline), "label": args.baseline_label} if args.baseline else None
        ),
        "rounds": args.rounds,
        "modules": modules,
        "rows": rows,
        **run_facts(before),
    }
    atomic_write_text(args.output, json.dumps(out, indent=1) + "\n")
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
