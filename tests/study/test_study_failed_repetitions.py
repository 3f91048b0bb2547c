"""A study whose demonstrations cannot finish keeps going: the lost repetitions are recorded as
failed (study.json, study.md), every other job and repetition completes, and the command exits 0.

The lost condition demonstrates for real with a 5-command budget; the other condition's
repetitions get a stand-in controller that always drives forward, so the test takes seconds."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from lfd_test_support import stand_in_learned
from study_helpers import write_study

import lfd_track.benchmark.runner as runner
from lfd_track.benchmark.runner import BenchmarkConfig
from lfd_track.cli import main
from lfd_track.methods.common import Learned
from lfd_track.study.jobs import expected_config
from lfd_track.study.spec import load_study
from lfd_track.study.summary import check_job_results, study_markdown

STUDY = """
[study]
name = "lost"
description = "a teacher who gives up after 5 commands beside one who finishes"
seeds = [0]
repetitions = 2

[defaults]
trials_per_direction = 1
test_tracks = []

[[conditions]]
name = "lost"
method = "paper"
[conditions.human]
max_commands = 5

[[conditions]]
name = "found"
method = "paper"
"""


def test_a_study_with_lost_demonstrations_finishes_and_names_them(tmp_path, monkeypatch):
    real = runner.learn_repetition

    def learn(config: BenchmarkConfig, rep_dir: Path, **kwargs: Any) -> Learned:
        if config.human.max_commands == 5:
            return real(config, rep_dir, **kwargs)  # the real demonstrator, which gives up
        return stand_in_learned()

    monkeypatch.setattr(runner, "learn_repetition", learn)
    path = write_study(tmp_path, STUDY, "lost.toml")
    out = tmp_path / "out"
    assert main(["--quiet", "study", str(path), "--out", str(out)]) == 0

    study = load_study(path)
    summary = json.loads((out / "study.json").read_text(encoding="utf-8"))
    lost, found = summary["conditions"]
    assert lost["failed_repetitions"] == [
        {"seed": 0, "repetition": r, "failed": "demonstration exceeded 5 commands"} for r in (0, 1)
    ]
    assert "failed_repetitions" not in found
    # Scored 0 on every trial they would have run: 2 repetitions x 2 directions.
    assert (lost["training"]["trials"], lost["training"]["successes"]) == (4, 0)
    assert lost["failure_kinds"]["training"] == {"no_controller": 4}
    assert found["training"]["trials"] == 4
    assert "no_controller" not in found["failure_kinds"]["training"]
    assert lost["human_commands"]["per_repetition"] == 6  # what the lost human gave
    assert lost["training_accuracy"] is None  # no controller was learned
    table = (out / "study.md").read_text(encoding="utf-8")
    assert table == study_markdown(summary)
    assert "Failed repetitions" in table
    assert "| lost | 0 | 1 | demonstration exceeded 5 commands |" in table

    # Each job's results pass the study's own check, and are found finished: rerunning runs none.
    for job in study.jobs():
        results = json.loads((out / job.condition / "seed0" / "results.json").read_text())
        assert results["config"] == expected_config(job)
        check_job_results(results, 2, 1, ())
    assert main(["--quiet", "study", str(path), "--out", str(out)]) == 0


def test_the_check_refuses_a_malformed_failed_repetitions_list():
    import pytest

    base: dict[str, Any] = {"outcomes": [], "human_effort": {"total": {"commands": 1}}}
    for bad, message in (
        ({"repetition": 2, "failed": "x"}, "below 2"),
        ({"repetition": 0}, "say why"),
        ("rep 0", "must be an object"),
    ):
        with pytest.raises(ValueError, match=message):
            check_job_results({**base, "failed_repetitions": [bad]}, 2)
    with pytest.raises(ValueError, match="listed twice"):
        failed = [{"repetition": 0, "failed": "x"}] * 2
        check_job_results({**base, "failed_repetitions": failed}, 2)
