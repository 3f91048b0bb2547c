"""The lab notebook (benchmarks/experiments/) works as written: every ``lfd-track study`` command
in its READMEs and study files parses, names a study file that exists and writes where that study's
committed results are (so ``test_committed_studies.py``, which finds them complete, also shows the
command resumes them); every relative link of its READMEs resolves; the goal notebook has one
folder per round, in order, with one line per round at the top of its README."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from lfd_track.cli import build_parser

REPO = Path(__file__).resolve().parents[2]
EXPERIMENTS = REPO / "benchmarks" / "experiments"
GOAL = EXPERIMENTS / "goal"
# Text files of the notebook (committed results left out: they are outputs, not instructions).
NOTES = sorted(
    p
    for p in EXPERIMENTS.rglob("*")
    if p.suffix in {".md", ".toml", ".py"} and "results" not in p.relative_to(EXPERIMENTS).parts
)
READMES = [p for p in NOTES if p.suffix == ".md"]
STUDY = re.compile(r"lfd-track study [^`\n]*")
LINK = re.compile(r"\]\(([^)\s]+)\)")


def _commands() -> list[tuple[str, str]]:
    found = []
    for path in NOTES:
        for match in STUDY.finditer(path.read_text(encoding="utf-8")):
            if "--out" in match.group(0):
                found.append((str(path.relative_to(REPO)), match.group(0).strip()))
    return found


COMMANDS = _commands()


def test_the_notebook_has_study_commands():
    assert len(COMMANDS) >= 48


@pytest.mark.parametrize(("where", "command"), COMMANDS, ids=[f"{w}: {c}" for w, c in COMMANDS])
def test_a_study_command_parses_and_writes_beside_its_study(where, command):
    args = build_parser().parse_args(shlex.split(command)[1:])
    study = Path(args.study_file)
    assert (REPO / study).is_file(), f"{where}: {study} does not exist"
    if args.out.isupper():
        return  # a placeholder (DIR) for a folder of the reader's choice
    # A study written but not yet run sits in planned/ and writes where it will sit once run.
    home = study.parent.parent if study.parent.name == "planned" else study.parent
    assert Path(args.out) == home / "results" / study.stem, f"{where}: --out {args.out}"


@pytest.mark.parametrize("readme", READMES, ids=[str(p.relative_to(EXPERIMENTS)) for p in READMES])
def test_every_relative_link_of_a_readme_resolves(readme):
    missing = []
    for match in LINK.finditer(readme.read_text(encoding="utf-8")):
        target = match.group(1).split("#", 1)[0]
        if target and not re.match(r"^[a-z]+:", target) and not (readme.parent / target).exists():
            missing.append(target)
    assert missing == []


def test_the_goal_notebook_has_one_folder_and_one_line_per_round_in_order():
    folders = sorted(p.name for p in GOAL.glob("round*") if p.is_dir())
    assert len(folders) >= 18
    assert folders == [f"round{n:02d}" for n in range(1, len(folders) + 1)]
    rows = re.findall(
        r"^\| \[(\d+)\]\((round\d+)/README\.md\) \|",
        (GOAL / "README.md").read_text(encoding="utf-8"),
        re.M,
    )
    assert [(int(n), f) for n, f in rows] == [
        (n, f"round{n:02d}") for n in range(1, len(folders) + 1)
    ]
    for n, folder in enumerate(folders, 1):
        title = (GOAL / folder / "README.md").read_text(encoding="utf-8").splitlines()[0]
        assert title.startswith(f"# Round {n}: "), title
        assert list((GOAL / folder).glob("*.toml")), f"{folder} holds no study file"
