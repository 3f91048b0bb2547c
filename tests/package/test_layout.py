"""The tests mirror the package: each test module sits in the folder of the subpackage it tests.

``tests/<name>/`` holds the tests of ``lfd_track/<name>/``; ``tests/package/`` holds the tests of
the package as a whole (install, lock, extras, import graph, public names, the README and docs),
which test no single subpackage. No test module sits at ``tests/`` top level.
"""

from __future__ import annotations

from lfd_test_support import REPO, TESTS

#: Folders of ``tests/`` that are not a subpackage: the package-wide tests and committed files.
NOT_SUBPACKAGES = {"package", "data"}


def test_no_test_module_at_the_top_level():
    assert sorted(p.name for p in TESTS.glob("test_*.py")) == []


def test_every_test_folder_names_a_subpackage():
    subpackages = {p.parent.name for p in (REPO / "lfd_track").glob("*/__init__.py")}
    folders = {p.name for p in TESTS.iterdir() if p.is_dir() and not p.name.startswith((".", "_"))}
    assert folders - NOT_SUBPACKAGES <= subpackages, sorted(folders - NOT_SUBPACKAGES - subpackages)


def test_test_module_names_are_unique():
    # The test folders are not packages, so pytest imports each module by its file name alone.
    names = [p.name for p in TESTS.rglob("test_*.py")]
    assert sorted({n for n in names if names.count(n) > 1}) == []
