"""``benchmarks/experiments/generalization/rules.py`` on a condition of ``trials/sharp_corners.toml``,
with two additions, neither of which changes a command the rules give in the paper world:

* the ``fresh_felt`` map takes the geometry of the condition's preset
  (``MapGeometry.from_preset``): rules.py builds the rules' perception without a geometry, so its
  map always assumes the paper's camera and 22.9 deg per pivot, whatever the preset. In the
  ``paper`` preset both are the same geometry (identical laps); under ``wide`` or the half-pivot
  preset the map would otherwise put the regions where the paper camera looks and turn by twice
  the half-pivot rover's pivot.
* every procedural-loop lap's trace is kept (pose after each command, the command, the map's
  three inputs, the track's corners) in ``OUT/traces/<rule>_rep<k>.npz`` for ``classify.py``.

    .venv/bin/python benchmarks/experiments/sharp_corners/run_rules.py \
        --condition paper --repetitions 2 --workers 1

Writes ``OUT/<rule>/seed0/results.json`` and ``OUT/rules.md`` as rules.py does (OUT defaults to
``results/<condition>`` here). ``--map KEY=VALUE`` and ``--rule NAME`` (repeatable) are passed on to rules.py (part
31: the goal's map settings).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

import lfd_track.benchmark.runner as runner
from lfd_track.envs.presets import load_preset
from lfd_track.policy.map_geometry import MapGeometry
from lfd_track.study.spec import load_study
from lfd_track.teaching.perception import Perception

HERE = Path(__file__).resolve().parent
RULES_PY = HERE.parent / "generalization" / "rules.py"
STUDY = HERE / "trials" / "sharp_corners.toml"

_spec = importlib.util.spec_from_file_location("rules", RULES_PY)
rules = importlib.util.module_from_spec(_spec)
sys.modules["rules"] = rules  # the pool's workers (forked) find its functions by this name
_spec.loader.exec_module(rules)

STATE: dict[str, Any] = {"geometry": None, "out": None, "traces": []}


def perception_with_geometry(self: Any) -> Perception:
    config = rules.RULES[self.rule]
    return Perception(self.library, "frozen", config.memory, geometry=STATE["geometry"])


_run_trial = runner.run_trial


def traced_run_trial(env: Any, controller: Any, *, seed: int | None, **kw: Any) -> Any:
    steps: list[list[float]] = []

    def on_loop_step(step: Any) -> None:
        pose = step.info_after.get("pose")
        if pose is None:
            return
        memory = np.asarray(step.percept.memory, dtype=float)
        mem = list(memory[-3:]) if len(memory) >= 3 else [np.nan] * 3
        steps.append([*map(float, pose[:3]), float(int(step.command)), *mem])

    info, trajectory, n = _run_trial(env, controller, seed=seed, on_loop_step=on_loop_step, **kw)
    track = env.unwrapped.track if hasattr(env, "unwrapped") else env.track
    STATE["traces"].append(
        {
            "track": track.name,
            "reversed": bool(track.reversed),
            "corners": [
                [c.label, *map(float, track.vertices[c.vertex]), c.turn_deg, c.s_m]
                for c in track.corners
            ],
            "first_xy": list(map(float, trajectory[0])) if len(trajectory) else None,
            "steps": steps,
        }
    )
    return info, trajectory, n


_run_loop_trials = rules.run_loop_trials


def traced_run_loop_trials(
    controller: Any, *, trial_seed: int, config: Any, repetition: int = 0, **kw: Any
):
    STATE["traces"] = []
    outcomes, record = _run_loop_trials(
        controller, trial_seed=trial_seed, config=config, repetition=repetition, **kw
    )
    traces = STATE["traces"]
    assert len(traces) == len(outcomes), (len(traces), len(outcomes))
    laps = []
    for o, t in zip(outcomes, traces, strict=True):
        assert o.track == t["track"]
        laps.append(
            {
                **t,
                "direction": o.direction,
                "success": bool(o.success),
                "failure": o.failure,
                "corner_order": list(o.corner_order),
                "corners_reached": list(o.corners_reached),
                "corners_negotiated": list(o.corners_negotiated),
            }
        )
    folder = STATE["out"] / "traces"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{controller.rule}_rep{repetition}.json"
    path.write_text(json.dumps(laps), encoding="utf-8")
    return outcomes, record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--condition", required=True)
    parser.add_argument("--repetitions", type=int, default=2)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument(
        "--first",
        type=int,
        default=0,
        help="run only repetitions FIRST..N-1 of the first N (the same repetitions, seeds and"
        " indices as a run of N; results.json then holds only those)",
    )
    parser.add_argument(
        "--map",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="passed on to rules.py: the map rule's map with that setting changed (repeatable)",
    )
    parser.add_argument(
        "--rule", action="append", default=[], help="passed on to rules.py: score only this rule"
    )
    args = parser.parse_args()
    condition = next(c for c in load_study(STUDY).conditions if c.name == args.condition)
    out = args.out or HERE / "results" / args.condition
    STATE["geometry"] = MapGeometry.from_preset(load_preset(condition.config.preset))
    STATE["out"] = out
    print(f"map geometry: {STATE['geometry']}", flush=True)
    rules.RuleController.perception = perception_with_geometry
    runner.run_trial = traced_run_trial  # run_loop_trials looks it up in the runner module
    rules.run_loop_trials = traced_run_loop_trials
    sys.argv = [
        str(RULES_PY),
        "--study", str(STUDY),
        "--condition", args.condition,
        "--out", str(out),
        "--repetitions", str(args.repetitions),
        "--workers", str(args.workers),
        *(arg for setting in args.map for arg in ("--map", setting)),
        *(arg for rule in args.rule for arg in ("--rule", rule)),
    ]  # fmt: skip
    if args.first:
        first = args.first
        seeds_of = rules.repetition_seeds
        rules.repetition_seeds = lambda seed, n: seeds_of(seed, n)[first:]
        STATE["first"] = first
        rules.run_repetition = offset_run_repetition
    rules.main()


_run_repetition = rules.run_repetition


def offset_run_repetition(job: tuple) -> dict:
    """rules.run_repetition with the repetition's index in the full run (``--first``)."""
    seed, index, repetition_seed, config = job
    return _run_repetition((seed, index + STATE["first"], repetition_seed, config))


if __name__ == "__main__":
    main()
