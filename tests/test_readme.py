"""Every Python block in the README runs as written (each on its own, in an empty folder)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"^```python\n(.*?)^```", README.read_text(encoding="utf-8"), re.M | re.S)


def test_readme_has_python_examples():
    assert len(BLOCKS) >= 3


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_readme_python_block_runs(index, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code = compile(BLOCKS[index], f"README.md python block {index + 1}", "exec")
    exec(code, {"__name__": f"readme_block_{index + 1}"})


def test_quick_start_is_two_commands():
    text = README.read_text(encoding="utf-8")
    quick = text.split("## Quick start", 1)[1].split("```", 2)[1]
    commands = [line for line in quick.splitlines() if line.strip()]
    assert [c.split()[:2] for c in commands] == [["make", "benchmark"], ["make", "test"]]


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
