"""Studies and the benchmark take the half-size camera (preset ``paper_fast``)."""

from __future__ import annotations

import json

from study_helpers import TINY_STUDY, write_study

from lfd_track.cli import main
from lfd_track.policy.controller import Controller


def test_a_tiny_study_runs_with_the_half_camera(tmp_path):
    from lfd_track.study.run import load_finished, run_study
    from lfd_track.study.spec import load_study
    from lfd_track.study.summary import write_study_outputs

    text = TINY_STUDY.replace("seeds = [0, 1]", "seeds = [0]").replace(
        'preset = "paper"', 'preset = "paper_fast"'
    )
    study = load_study(write_study(tmp_path, text))
    out = tmp_path / "out"
    run_study(study, out, executor="local", workers=1)
    write_study_outputs(out, study, load_finished(study, out))
    assert (out / "study.json").is_file()
    results = json.loads((out / "paper" / "seed0" / "results.json").read_text())
    assert results["config"]["preset"] == "paper_fast"
    assert results["outcomes"]  # the trials ran


def test_the_benchmark_runs_with_the_half_camera(tmp_path):
    out = tmp_path / "b"
    argv = ["--quiet", "benchmark", "--quick", "--workers", "1", "--preset", "paper_fast"]
    assert main([*argv, "--out", str(out)]) == 0
    results = json.loads((out / "results.json").read_text())
    assert results["config"]["preset"] == "paper_fast"
    controllers = sorted(out.rglob("*controller*.json"))
    assert controllers and all(Controller.load(p).frame_size == (320, 240) for p in controllers)
