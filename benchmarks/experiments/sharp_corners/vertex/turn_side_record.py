"""Record the fresh-felt map's arrays at EVERY command of every lap (for ``turn_side.py``).

Drives exactly as ``vertex_maps.py`` does (the map rule of ``../../generalization/rules.py``,
trials of ``../trials/sharp_corners.toml``, condition ``paper``); ``FreshFeltMemory.see`` is
wrapped (the library is untouched, nothing the rover does changes) and after it returns a
cropped copy of the map is kept: felt points (level >= 0.25) within 1.6 m of the axle and every
point weighing in the fresh centre, their levels and fresh weights, and the path. Unlike
``vertex_maps.py`` this keeps every lap (gentle loops too) and every command, so that ordinary
driving can be scored as well.

    .venv/bin/python benchmarks/experiments/sharp_corners/vertex/turn_side_record.py --repetitions 0 1 2 3 4 5

Writes ``vertex/turnside_rep<k>.pkl.gz`` (not committed).
"""

from __future__ import annotations

import argparse
import gzip
import importlib.util
import pickle
import sys
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent


def _load(name: str, path: Path) -> Any:
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


vm = _load("vertex_maps", HERE / "vertex_maps.py")
runner = vm.runner
memory_module = vm.memory_module
FreshFeltMemory = vm.FreshFeltMemory
CROP_M = 1.6
STATE: dict[str, Any] = {"snap": None}  # the laps go to vm.STATE["laps"], as vm.drive reads them
_see = FreshFeltMemory.see


def see_and_copy(self: Any, values: np.ndarray, levels: Any = None) -> None:
    _see(self, values, levels)
    points = self._points
    dist, _, own, weights, used = vm.fresh_weights(self)
    keep = ((self._felt >= 0.25) & (dist < CROP_M)) | (weights > 0)
    STATE["snap"] = {
        "points": points[keep].astype(np.float32),
        "felt": self._felt[keep].astype(np.float16),
        "weights": weights[keep].astype(np.float16),
        "own": own[keep],
        "path": self._path.astype(np.float32),
        "used": used,
    }


def traced_run_trial(env: Any, controller: Any, *, seed: int | None, **kw: Any) -> Any:
    track = env.unwrapped.track if hasattr(env, "unwrapped") else env.track
    steps: list[list[float]] = []
    snaps: dict[int, dict] = {}
    STATE["snap"] = None

    def on_loop_step(step: Any) -> None:
        k = len(steps)
        steps.append(vm.step_row(step))
        if STATE["snap"] is not None:
            snaps[k] = STATE["snap"]
        STATE["snap"] = None

    info, trajectory, n = vm._run_trial(env, controller, seed=seed, on_loop_step=on_loop_step, **kw)
    vm.STATE["laps"].append({
        "track": track.name, "direction": "cw" if track.reversed else "ccw",
        "success": bool(info["success"]), "failure": info["failure"],
        "steps": np.asarray(steps, dtype=np.float64), "snaps": snaps,
    })  # fmt: skip
    return info, trajectory, n


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repetitions", type=int, nargs="+", default=[0, 1, 2, 3, 4, 5])
    args = parser.parse_args()
    FreshFeltMemory.see = see_and_copy
    runner.run_trial = traced_run_trial
    for rep in args.repetitions:
        laps = vm.drive(rep)
        with gzip.open(HERE / f"turnside_rep{rep}.pkl.gz", "wb") as fh:
            pickle.dump(laps, fh)
        print(f"rep {rep}: {sum(x['success'] for x in laps)}/{len(laps)} laps lapped", flush=True)


if __name__ == "__main__":
    main()
