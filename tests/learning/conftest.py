"""A recorded demonstration on the training track, shared by the learner tests."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import run_demonstration


@pytest.fixture(scope="session")
def demo_cases(tmp_path_factory) -> tuple[np.ndarray, np.ndarray]:
    """Road values (N, 40) and commands (N,) of the default scripted demonstration (seed 3)."""
    path = tmp_path_factory.mktemp("learning-demo") / "d.lfdemo"
    run_demonstration(path, seed=3, fsync=False)
    demo = load_demonstration(path)
    return demo.road_values, demo.commands.astype(np.intp)
