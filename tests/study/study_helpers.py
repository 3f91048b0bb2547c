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
