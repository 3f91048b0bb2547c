"""The teaching loop arranged for the browser station (provisional until the loop package lands).

PROVISIONAL: this steps library → road values → command → record → robot itself, only so the web
stack can be exercised; it is replaced by the teaching loop's perception, arbiter and observers.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..commands import Command
from ..demo.dataset import DemonstrationWriter
from ..vision.road_library import RoadLibrary


class TeachArrangement:
    def __init__(
        self,
        env: Any,
        out: str | Path,
        *,
        metadata: dict[str, Any],
        seed: int | None,
        simulated: bool,
        library_only: int = 0,
        overwrite: bool = False,
    ) -> None:
        self.env = env
        self.seed = seed
        self.simulated = simulated
        self.library = RoadLibrary()
        self.library_only = library_only
        self.paused = False
        self.auto_paused = False
        self.writer = DemonstrationWriter(
            out, metadata, self.library.bins, overwrite=overwrite, fsync=True
        )
        self.commands_given = 0
        self.frame: np.ndarray | None = None
        self.info: dict[str, Any] = {}
        self.policy_ready = False
        self._counts = dict.fromkeys(("forward", "left", "right"), 0)

    def reset(self, options=None) -> None:
        self.frame, self.info = self.env.reset(seed=self.seed, options=options)

    def step(self, human: Command | None) -> str | None:
        frame = self.frame
        on_felt = bool(self.info.get("safe_box_on_felt", True))
        self.auto_paused = not on_felt
        learn = not self.paused and on_felt
        if learn:
            self.library.learn(frame)
        hists = self.library.region_histograms(frame)
        values = self.library.road_values_from_histograms(hists)
        command = human
        self.commands_given += 1
        if self.commands_given > self.library_only:
            pose = self.env.rover_pose if self.simulated else None
            self.writer.append(int(command), values, hists, pose=pose, learned=learn)
            self._counts[command.name.lower()] += 1
        self.frame, _, terminated, truncated, self.info = self.env.step(int(command))
        if terminated or truncated:
            reason = self.info.get("failure") or "episode end"
            if self.simulated:
                self.reset()
                return f"{reason}: back to the start"
            return str(self.info.get("error", reason))
        return None

    def display(self) -> tuple[np.ndarray, np.ndarray, str]:
        values = self.library.road_values(self.frame, update_statistics=False)
        return self.frame, values, ""

    def status(self) -> dict[str, Any]:
        return {
            "cases": self.writer.n_cases,
            "counts": dict(self._counts),
            "corrections": 0,
            "learning_paused": self.paused,
            "learning_auto_paused": self.auto_paused,
            "library_models": self.library.n_models,
            "generation": None,
            "best_fitness": None,
            "agreement": None,
            "policy_ready": False,
            "takeover_offered": False,
        }

    def set_learning_paused(self, paused: bool) -> None:
        self.paused = paused

    def policy_takes_over(self) -> None:
        raise ValueError("no policy")

    def human_takes_back(self, record: bool = True) -> None:
        pass

    def close(self) -> None:
        self.writer.close({"road_library": self.library.to_dict()})
        self.env.close()
