"""Round 26, an exploratory look at the mechanism: road values across camera sessions.

Round 26 found that the camera session's white-balance cast carries a room's cost. A session
(``LfDTrackEnv.reset`` with a new seed, which rebuilds the world and redraws the camera's cast and
noise) colours every frame it takes; the road library is taught in one session and driven in
others. Here, in the paper world and round 22's ten rooms (seed 100, drawn as the studies draw
them), the centreline driver laps the testing track while a careful perception learns its library
from empty (session 0, as ``../../robustness/felt_levels.py``'s separation does); then the frozen
library reads views from every second pose of that lap taken in sessions 0-4 of the same world
(session 0 is the teaching session itself). Each view is scored against the world's truth: the
share of clearly felt or clearly carpet regions (at least 3/4 or at most 1/4 felt) whose felt
level (the fixed levels) lies on the right side of 0.5.

Beside no correction, one simple candidate for the next design: each session's frames scaled per
channel by the session's running mean colour (grey world over the session), in teaching and in
reading. Exploratory: nothing is decided on it; it says whether the score sees the sessions and
how far the simplest correction goes. Added with round 27: the design built since,
``colour_balance = "safe_box"`` (``lfd_track/vision/colour_balance.py``): teaching as without a
correction, and each session's views read by a frozen perception with the balance, which
estimates that session's gains from the views it is shown, in order.

    .venv/bin/python benchmarks/experiments/human_goal/round26/cross_session.py --workers 2

Writes ``results/cross_session.md`` (well under a minute on two workers).
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from lfd_track.benchmark.runner import repetition_preset, repetition_seeds
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.policy.memory_config import FreshFeltConfig
from lfd_track.study.spec import load_study
from lfd_track.teaching.perception import Perception
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.world.driver import CentrelineDriver

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from room_measures import robustness_felt_levels, write_page  # noqa: E402

OUT = HERE / "results"
STUDY = HERE.parent / "round22" / "room_parts.toml"
SESSIONS = (0, 1, 2, 3, 4)
CORRECTIONS = ("none", "session grey world", "safe-box balance")


class _SessionBalance:
    """A session's running mean colour, and frames scaled by it to equal channel means."""

    def __init__(self, on: bool) -> None:
        self.on, self.total, self.frames = on, np.zeros(3), 0

    def __call__(self, frame: np.ndarray) -> np.ndarray:
        if not self.on:
            return frame
        self.total += frame.reshape(-1, 3).mean(axis=0)
        self.frames += 1
        means = self.total / self.frames
        gains = means.mean() / np.maximum(means, 1e-6)
        return np.clip(frame * gains[None, None, :], 0, 255).astype(np.uint8)


def _scores(job: tuple[str, Any, str]) -> tuple[str, str, list[float]]:
    name, world, correction = job
    fl = robustness_felt_levels()
    env = LfDTrackEnv(track="testing", preset=world)
    obs, info = env.reset(seed=0)
    driver = CentrelineDriver(env.track)
    perception = Perception(RoadLibrary(), "careful", FreshFeltConfig())
    balance = _SessionBalance(correction == "session grey world")
    poses = []
    for _ in range(env.max_steps):
        pose = np.asarray(info["pose"])
        poses.append(pose)
        perception.perceive(balance(obs), info["safe_box_on_felt"])
        obs, _, terminated, truncated, info = env.step(int(driver.act(pose, info["progress_m"])))
        if terminated or truncated:
            break
    scores = []
    for session in SESSIONS:
        if session == 0:
            view_env = env
        else:
            view_env = LfDTrackEnv(track="testing", preset=world)
            view_env.reset(seed=session)
        rng = np.random.default_rng(5)
        balance = _SessionBalance(correction == "session grey world")
        reader = Perception(
            perception.library, "frozen", FreshFeltConfig(colour_balance="safe_box")
        )
        right = total = 0
        for pose in poses[::2]:
            view = balance(view_env.view_from(pose, rng))
            if correction == "safe-box balance":
                values = reader.perceive(view).values
            else:
                values = perception.look(view)
            share = fl.felt_share(view_env, pose)
            level = fl.felt_level(values, None)
            felt, carpet = share >= 0.75, share <= 0.25
            right += int(((level >= 0.5) & felt).sum() + ((level < 0.5) & carpet).sum())
            total += int(felt.sum() + carpet.sum())
        scores.append(right / total)
    return name, correction, scores


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=1)
    args = parser.parse_args()
    config = next(c.config for c in load_study(STUDY).conditions if c.name.startswith("rooms."))
    worlds: list[tuple[str, Any]] = [("paper world", "paper")]
    worlds += [
        (f"room {k}", repetition_preset(config, seed))
        for k, seed in enumerate(repetition_seeds(100, 10))
    ]
    jobs = [(name, world, c) for name, world in worlds for c in CORRECTIONS]
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        results = {(n, c): s for n, c, s in pool.map(_scores, jobs)}
    lines = [
        "# Road values across camera sessions (exploratory)",
        "",
        "Share of clearly felt or clearly carpet regions read on the right side of 0.5 by a library",
        "taught in session 0, on views from the teaching lap's poses taken in sessions 0-4.",
        "",
        "| world | correction | session 0 (taught) | sessions 1-4 | worst of 1-4 |",
        "|---|---|---|---|---|",
    ]
    for name, _ in worlds:
        for c in CORRECTIONS:
            s = results[(name, c)]
            others = ", ".join(f"{v:.3f}" for v in s[1:])
            lines.append(f"| {name} | {c} | {s[0]:.3f} | {others} | {min(s[1:]):.3f} |")
    for c in CORRECTIONS:
        pooled = [v for name, _ in worlds for v in results[(name, c)][1:]]
        taught = [results[(name, c)][0] for name, _ in worlds]
        lines.append("")
        lines.append(
            f"{c}: session 0 mean {np.mean(taught):.3f}; sessions 1-4 mean {np.mean(pooled):.3f},"
            f" worst {min(pooled):.3f}."
        )
    write_page(OUT / "cross_session.md", lines)


if __name__ == "__main__":
    main()
