"""``--executor ray``: the tiny study as Ray tasks on a local Ray gives the local results.

Without Ray this test is skipped, except under CI=true, where it fails: the test extra installs
Ray, so its absence is a broken build.
"""

from __future__ import annotations

import importlib.util
import json
import os

from lfd_test_support import unavailable

from lfd_track.cli import main
from lfd_track.study.jobs import RESULTS_FILE


def _need_ray() -> None:
    if importlib.util.find_spec("ray") is None:
        unavailable("the Ray executor test needs Ray (pip install 'lfd-track[cluster]')")


def test_ray_executor_gives_the_local_results(tiny_study, tmp_path, capsys):
    _need_ray()
    path, local_out, _ = tiny_study
    out = tmp_path / "ray"
    args = ["--quiet", "study", str(path), "--out", str(out), "--executor", "ray", "--workers", "2"]
    assert main(args) == 0, capsys.readouterr().err
    assert "2 jobs run, 0 already finished" in capsys.readouterr().out
    assert os.environ["RAY_USAGE_STATS_ENABLED"] == "0"  # no usage reports over the network
    for seed in (0, 1):
        local = json.loads((local_out / "paper" / f"seed{seed}" / RESULTS_FILE).read_text())
        ray = json.loads((out / "paper" / f"seed{seed}" / RESULTS_FILE).read_text())
        # Like the timing, the environment is where the job ran (Ray's workers, for one, run
        # with their own BLAS thread count); it is recorded, and compared here, apart.
        for results in (local, ray):
            results.pop("timing_s")
            assert results.pop("environment")["blas"] is not None
        assert ray == local
    local_summary = json.loads((local_out / "study.json").read_text())
    ray_summary = json.loads((out / "study.json").read_text())
    for summary in (local_summary, ray_summary):
        summary.pop("wall_s")
        summary.pop("environment")
        assert len(summary.pop("job_environments")) >= 1
        for condition in summary["conditions"]:
            condition.pop("wall_s")
            for seed in condition["per_seed"]:
                seed.pop("wall_s")
    assert ray_summary == local_summary
