"""The package's modules import each other without cycles.

Every module of ``lfd_track`` is read with :mod:`ast` (nothing is imported). Each ``import`` and
``from … import …`` statement counts, at module level and inside functions, classes and
``if TYPE_CHECKING:`` blocks alike: a cycle that only a function-level import hides still ties
the two modules together. Relative imports are resolved against the importing module.

How a statement becomes edges:

- ``import a.b.c`` and ``from a.b.c import name`` give an edge to ``a.b.c``;
- ``from a.b import c`` where ``a.b.c`` is a module of the package gives an edge to ``a.b.c``
  (the submodule), not to the package ``a.b``;
- ``from a.b import name`` where ``name`` is not a submodule gives an edge to ``a.b``, that is
  to the package's ``__init__``, since the name comes from its re-exports.

Package ``__init__`` modules are nodes like any other, with the edges of their own re-exports.
Importing ``a.b.c`` runs ``a/b/__init__.py`` first, but that is Python initialising the parent,
not a dependency of the importing module, so it adds no edge to ``a.b``: otherwise every
``__init__`` that re-exports its submodules would close a false cycle with each of them. A
module that imports a name *from* a package's ``__init__`` does depend on everything that
``__init__`` re-exports, and a cycle through it is reported.
"""

from __future__ import annotations

import ast
from pathlib import Path

import lfd_track

PACKAGE = "lfd_track"
ROOT = Path(lfd_track.__file__).resolve().parent


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def package_modules() -> dict[str, Path]:
    return {_module_name(path): path for path in sorted(ROOT.rglob("*.py"))}


def _resolve(module: str, is_package: bool, level: int, target: str | None) -> str:
    base = module.split(".") if is_package else module.split(".")[:-1]
    if level > 1:
        base = base[: len(base) - (level - 1)]
    return ".".join([*base, target] if target else base)


def imports_of(module: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The package modules that ``module`` imports, by the rules of this file's docstring."""
    is_package = path.name == "__init__.py"
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name in modules:
                    found.add(alias.name)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                source = _resolve(module, is_package, node.level, node.module)
            else:
                source = node.module or ""
            if source != PACKAGE and not source.startswith(PACKAGE + "."):
                continue
            for alias in node.names:
                submodule = f"{source}.{alias.name}"
                if submodule in modules:
                    found.add(submodule)
                elif source in modules:
                    found.add(source)
    found.discard(module)
    return found


def import_graph() -> dict[str, set[str]]:
    modules = package_modules()
    return {name: imports_of(name, path, modules) for name, path in modules.items()}


def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One cycle per strongly connected component with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def connect(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph[node]):
            if nxt not in index:
                connect(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            connect(node)
    return [_cycle_in(graph, set(component)) for component in components]


def _cycle_in(graph: dict[str, set[str]], component: set[str]) -> list[str]:
    """A shortest cycle through the component's first module, as a path that ends where it began."""
    start = min(component)
    parents: dict[str, str] = {}
    frontier = [start]
    while frontier:
        following = []
        for node in frontier:
            for nxt in sorted(graph[node] & component):
                if nxt == start:
                    path = [node]
                    while path[-1] != start:
                        path.append(parents[path[-1]])
                    return [start, *reversed(path[:-1]), start]
                if nxt not in parents:
                    parents[nxt] = node
                    following.append(nxt)
        frontier = following
    raise AssertionError(f"no cycle in component {sorted(component)}")


def test_the_graph_sees_function_level_and_relative_imports():
    graph = import_graph()
    assert len(graph) > 50
    # `from .track_file import …` at module level, resolved against lfd_track.world.
    assert "lfd_track.world.track_file" in graph["lfd_track.world.track"]
    # `from .app import create_app, …` inside the function that runs the command.
    assert "lfd_track.web.app" in graph["lfd_track.cli.teach"]
    # `from .arbiter import …` in a package __init__ re-exporting its submodules.
    assert "lfd_track.teaching.arbiter" in graph["lfd_track.teaching"]
    # `from ...errors import …` three levels up, from a subpackage of a subpackage.
    assert "lfd_track.errors" in graph["lfd_track.dataset.minari.store"]


def test_the_graph_holds_every_module_of_the_package():
    files = sorted(ROOT.rglob("*.py"))
    graph = import_graph()
    assert len(graph) == len(files)
    nested = {"lfd_track", "lfd_track.dataset.minari", "lfd_track.dataset.minari.export"}
    assert nested <= set(graph)
    for edges in graph.values():
        assert edges <= set(graph)


def test_find_cycles_reports_a_cycle_and_ignores_a_chain():
    assert find_cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []
    assert find_cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c", "a"]]


def test_package_has_no_import_cycle():
    cycles = find_cycles(import_graph())
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(cycle) for cycle in cycles)
