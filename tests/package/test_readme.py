"""The README and every page under docs/ work as written.

Every Python block runs (each on its own, in an empty folder); every TOML block is a valid study
file (a fragment of conditions is completed with a one-seed header); every ``lfd-track`` command
in a shell block parses with the real command line, and every repository file a command names
exists; every relative link and image resolves to a file of the repository.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from lfd_test_support import REPO

from lfd_track.cli import build_parser

README = REPO / "README.md"
PAGES = [README, *sorted((REPO / "docs").glob("*.md"))]
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.M | re.S)


def _name(page: Path) -> str:
    return str(page.relative_to(REPO))


def _blocks(language: str) -> list[tuple[str, int, str]]:
    found = []
    for page in PAGES:
        blocks = [
            b for lang, b in FENCE.findall(page.read_text(encoding="utf-8")) if lang == language
        ]
        found += [(_name(page), i + 1, block) for i, block in enumerate(blocks)]
    return found


PYTHON = _blocks("python")
TOML = _blocks("toml")
SHELL = _blocks("")


def _ids(blocks):
    return [f"{page}-{index}" for page, index, _ in blocks]


def test_the_docs_have_examples():
    assert len(PYTHON) >= 5 and len(TOML) >= 2 and len(SHELL) >= 6
    assert len(PAGES) >= 10


@pytest.mark.parametrize(("page", "index", "block"), PYTHON, ids=_ids(PYTHON))
def test_python_block_runs(page, index, block, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code = compile(block, f"{page} python block {index}", "exec", dont_inherit=True)
    exec(code, {"__name__": f"doc_block_{index}"})


STUDY_HEADER = '[study]\nname = "doc"\nseeds = [0]\nrepetitions = 1\n\n'


@pytest.mark.parametrize(("page", "index", "block"), TOML, ids=_ids(TOML))
def test_toml_block_is_a_valid_study(page, index, block, tmp_path):
    from lfd_track.study.spec import load_study

    text = block if "[study]" in block else STUDY_HEADER + block
    path = tmp_path / "doc.toml"
    path.write_text(text, encoding="utf-8")
    assert load_study(path).conditions


def _commands(block: str) -> list[list[str]]:
    """The command lines of a shell block (continuations joined, comments dropped), as words."""
    commands, current = [], []
    for raw in block.splitlines():
        line = raw.rstrip()
        continued = line.endswith("\\")
        current += shlex.split(line[:-1] if continued else line, comments=True)
        if not continued:
            if current:
                commands.append(current)
            current = []
    return commands


@pytest.mark.parametrize(("page", "index", "block"), SHELL, ids=_ids(SHELL))
def test_shell_block_commands_parse_and_name_existing_files(page, index, block):
    parser = build_parser()
    for words in _commands(block):
        if words[0] == "lfd-track" and not any(w.startswith("[") or w == "|" for w in words):
            parser.parse_args(words[1:])  # a synopsis line ([--option], a | b) is not a command
        for word in words:
            # Files of the repository named by a command (scripts, study files): they must exist.
            if re.match(r"^(benchmarks|scripts|tracks|envs|hardware)/\S+\.(py|toml)$", word):
                assert (REPO / word).is_file(), f"{page}: {word} does not exist"


LINK = re.compile(r"\]\(([^)\s]+)\)|<img [^>]*src=\"([^\"]+)\"")


@pytest.mark.parametrize("page", PAGES, ids=[_name(p) for p in PAGES])
def test_every_relative_link_resolves(page):
    missing = []
    for match in LINK.finditer(page.read_text(encoding="utf-8")):
        target = (match.group(1) or match.group(2)).split("#", 1)[0]
        if not target or re.match(r"^[a-z]+:", target):
            continue  # an anchor in the page, or a URL
        if not (page.parent / target).exists():
            missing.append(target)
    assert missing == []


def test_quick_start_is_two_commands():
    text = README.read_text(encoding="utf-8")
    quick = text.split("## Quick start", 1)[1].split("```", 2)[1]
    commands = [line for line in quick.splitlines() if line.strip()]
    assert [c.split()[:2] for c in commands] == [["make", "benchmark"], ["make", "test"]]


def test_readme_is_short():
    assert len(README.read_text(encoding="utf-8").splitlines()) <= 250


def test_docs_cite_only_files_in_the_repository():
    # Users have the repository, not the project's design notes: no references to those.
    root = README.parent
    outside = re.compile(
        r"\b" + "DESI" + r"GN\b|/work/" + "shared|" + r"\.\./" + "shared|" + "STY" + r"LE\.md"
    )
    suffixes = {".md", ".py", ".toml", ".ino", ".c", ".h", ".txt", ".cfg"}
    offenders = []
    for path in root.rglob("*"):
        parts = path.relative_to(root).parts
        if path.suffix not in suffixes or parts[0].startswith(".") or parts[0] == "results":
            continue
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if outside.search(line):
                offenders.append(f"{path.relative_to(root)}:{number}: {line.strip()}")
    assert offenders == []
