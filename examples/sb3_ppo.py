"""Train PPO (Stable-Baselines3) on the road values, then score it like the paper's controllers.

An optional example, not part of the test suite. It needs Stable-Baselines3, which installs
torch: ``pip install stable-baselines3`` beside lfd-track.

1. The scripted human drives one demonstration on the training track (as ``lfd-track demo``);
   its road library turns each camera frame into the 40 road values (paper Algorithm 2), frozen.
2. PPO learns from the env's reward (metres of progress along the centreline, -1 on failure)
   on ``RoadValueObservation(LfDTrack-v0)``, after Stable-Baselines3's own ``check_env``.
3. ``lfd_track.evaluate`` scores the trained model with the corner-success protocol (runs both
   ways on the training track, laps both ways on the testing track from corner 4, counted corner
   by corner, Wilson 95 % intervals). The model is the policy: ``evaluate`` calls its
   ``predict``. This example is written against
   ``lfd_track.evaluate(policy, tracks=..., laps=..., seed=..., observation="road-values",
   library=...)``, where ``library`` is the road library the road values are computed with.

    python examples/sb3_ppo.py --steps 50000 --laps 3 --out ppo_road_values.zip
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import gymnasium as gym

import lfd_track
from lfd_track import RoadValueObservation, load_demonstration, run_demonstration


def road_library(seed: int, track: str):
    """The road library of one scripted demonstration (the paper's way to build it)."""
    with tempfile.TemporaryDirectory() as folder:
        demo = Path(folder) / "demo.lfdemo"
        run_demonstration(demo, seed=seed, track=track, fsync=False)
        return load_demonstration(demo).road_library()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=50_000, help="PPO time steps (commands)")
    parser.add_argument("--track", default="training", help="track PPO trains on")
    parser.add_argument("--seed", type=int, default=0, help="demonstration, PPO and world seed")
    parser.add_argument("--laps", type=int, default=3, help="runs per track and direction")
    parser.add_argument("--out", help="also save the trained model here (.zip)")
    args = parser.parse_args(argv)

    from stable_baselines3 import PPO
    from stable_baselines3.common.env_checker import check_env

    library = road_library(args.seed, args.track)
    env = RoadValueObservation(gym.make("LfDTrack-v0", track=args.track), library)
    check_env(env)
    model = PPO("MlpPolicy", env, seed=args.seed, verbose=1)
    model.learn(total_timesteps=args.steps)
    if args.out:
        model.save(args.out)

    evaluation = lfd_track.evaluate(
        model,
        tracks=("training", "testing"),
        laps=args.laps,
        seed=args.seed,
        observation="road-values",
        library=library,
    )
    print(evaluation.tables())
    print(f"PPO on road values: {evaluation.successes}/{evaluation.trials} runs succeeded")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
