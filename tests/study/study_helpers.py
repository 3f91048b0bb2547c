"""The tiny study file the study tests share."""

from __future__ import annotations

from pathlib import Path

TINY_STUDY = """
[study]
name = "tiny"
description = "smallest honest study: every part runs, nothing is measured"
seeds = [0, 1]
repetitions = 1

[defaults]
trials_per_direction = 1
[defaults.ga]
generations = 5

[[conditions]]
name = "paper"
method = "paper"
preset = "paper"
"""


def write_study(folder: Path, text: str = TINY_STUDY, name: str = "tiny.toml") -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def outcome(track="testing", direction="ccw", negotiated=("4", "1", "2", "3"), repetition=0):
    """One trial outcome as results.json stores it (a success when every corner was negotiated)."""
    order = ["4", "1", "2", "3"] if track == "testing" else ["1", "2"]
    success = list(negotiated) == order
    return {
        "track": track,
        "direction": direction,
        "corner_order": order,
        "corners_reached": list(negotiated),
        "corners_negotiated": list(negotiated),
        "failure": None if success else "off_track",
        "success": success,
        "repetition": repetition,
        "trial": 0,
        "steps": 10,
    }


def job_results(job) -> dict:
    """Smallest results.json a finished ``job`` could have written (by hand, without running)."""
    from lfd_track.study.jobs import expected_config

    return {
        "config": expected_config(job),
        "demonstrations": [{"cases": 150}],
        "outcomes": [
            outcome("training", "direction_1", ["1", "2"]),
            outcome("training", "direction_2", ["1"]),
            outcome("testing", "ccw"),
            outcome("testing", "cw", ["4"]),
        ],
        "timing_s": {"wall": 1.5},
        "training_accuracy": [0.5],
    }
