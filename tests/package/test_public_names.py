"""Scripts outside the package (benchmarks/, scripts/) use only lfd_track's public names.

A private name (``_x``) may change with any refactoring of its module; a script that needs a
helper gets it under a public name from the module that owns it.
"""

from __future__ import annotations

import ast

import pytest
from lfd_test_support import REPO

SCRIPTS = sorted(
    str(p.relative_to(REPO))
    for folder in ("benchmarks", "scripts")
    for p in (REPO / folder).rglob("*.py")
)


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def private_uses(source: str) -> list[str]:
    """Private lfd_track names a module imports or reads off an imported lfd_track module."""
    tree = ast.parse(source)
    bound: set[str] = set()  # local names of imported lfd_track modules and objects
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "lfd_track":
            if any(_private(part) for part in node.module.split(".")):
                found.append(f"line {node.lineno}: from {node.module}")
            for alias in node.names:
                if _private(alias.name):
                    found.append(f"line {node.lineno}: {alias.name} from {node.module}")
                bound.add(alias.asname or alias.name)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "lfd_track":
                    if any(_private(part) for part in alias.name.split(".")):
                        found.append(f"line {node.lineno}: import {alias.name}")
                    bound.add(alias.asname or alias.name.split(".")[0])
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _private(node.attr):
            base = node.value
            while isinstance(base, ast.Attribute):
                base = base.value
            if isinstance(base, ast.Name) and base.id in bound:
                found.append(f"line {node.lineno}: {ast.unparse(node)}")
    return found


def test_the_check_sees_private_names():
    source = (
        "from lfd_track.world.track_file import _check\n"
        "from lfd_track.learning import fitness\n"
        "import lfd_track.envs.track_env as env\n"
        "fitness._matches()\n"
        "env.LfDTrackEnv._reset\n"
        "fitness.__name__\n"
    )
    assert len(private_uses(source)) == 3


def test_there_are_scripts():
    assert len(SCRIPTS) >= 14


@pytest.mark.parametrize("script", SCRIPTS)
def test_script_uses_only_public_lfd_track_names(script):
    assert private_uses((REPO / script).read_text(encoding="utf-8")) == []
