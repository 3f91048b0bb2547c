"""requirements.lock, which the Makefile's setup targets install from, satisfies pyproject.toml.

pyproject.toml keeps open ranges for library users; the README's two commands (`make benchmark`,
`make test`) install the exact versions of the lock, which `make lock` writes anew.
"""

from __future__ import annotations

import re
import tomllib

import pytest
from lfd_test_support import REPO
from packaging.requirements import InvalidRequirement, Requirement
from packaging.utils import canonicalize_name
from packaging.version import Version

LOCK = REPO / "requirements.lock"


def read_lock(text: str) -> dict[str, Version]:
    """name -> exact version; ValueError naming the line unless every line is ``name==version``."""
    pins: dict[str, Version] = {}
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        try:
            req = Requirement(line)
        except InvalidRequirement as exc:
            raise ValueError(f"line {number}: {exc}") from None
        specs = list(req.specifier)
        if req.url or len(specs) != 1 or specs[0].operator != "==" or "*" in specs[0].version:
            raise ValueError(f"line {number}: {line!r} is not an exact pin (name==version)")
        name = canonicalize_name(req.name)
        if name in pins:
            raise ValueError(f"line {number}: {req.name} is pinned twice")
        pins[name] = Version(specs[0].version)
    return pins


def makefile_extras(makefile: str) -> set[str]:
    """Extras the Makefile installs the package with (``.[a,b]``, with make variables expanded)."""
    variables = dict(re.findall(r"^([A-Z_]+)\s*:?=\s*(.*?)\s*$", makefile, re.M))
    extras: set[str] = set()
    for group in re.findall(r"\.\[([^\]]+)\]", makefile):
        group = re.sub(r"\$\((\w+)\)", lambda m: variables.get(m[1], m[0]), group)
        extras |= {e.strip() for e in group.split(",") if e.strip()}
    return extras


def unsatisfied(pyproject: dict, extras: set[str], pins: dict[str, Version]) -> list[str]:
    """What the lock lacks: one line per requirement of the package, of each extra in ``extras``
    and of the build backend that the lock does not pin, or pins outside its range."""
    project = pyproject["project"]
    optional = project.get("optional-dependencies", {})
    wanted = [("dependencies", r) for r in project["dependencies"]]
    wanted += [("build-system", r) for r in pyproject["build-system"]["requires"]]
    for extra in sorted(extras):
        if extra not in optional:
            return [f"the Makefile installs extra {extra!r}, which pyproject.toml does not define"]
        wanted += [(f"extra {extra}", r) for r in optional[extra]]
    problems = []
    for where, text in wanted:
        req = Requirement(text)
        if req.marker is not None and not req.marker.evaluate():
            continue
        name = canonicalize_name(req.name)
        if name == canonicalize_name(project["name"]):
            continue  # an extra that names the package's other extras
        if name not in pins:
            problems.append(f"{where}: {text!r} is not in the lock")
        elif not req.specifier.contains(pins[name], prereleases=True):
            problems.append(f"{where}: the lock pins {req.name}=={pins[name]}, outside {text!r}")
    return problems


def _pyproject() -> dict:
    return tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))


def _makefile() -> str:
    return (REPO / "Makefile").read_text(encoding="utf-8")


def test_the_lock_pins_every_requirement_the_makefile_installs_within_its_range():
    pins = read_lock(LOCK.read_text(encoding="utf-8"))
    extras = makefile_extras(_makefile())
    assert {"test", "bench"} <= extras
    assert unsatisfied(_pyproject(), extras, pins) == []
    # The lock is the whole environment: the installer and transitive dependencies are pinned
    # too, and the project itself is not (it is installed from the checkout).
    assert {"pip", "packaging", "pluggy", "iniconfig", "websockets"} <= set(pins)
    assert "lfd-track" not in pins


def test_the_check_names_what_a_stale_lock_lacks():
    pins = read_lock(LOCK.read_text(encoding="utf-8"))
    pins["numpy"] = Version("1.20.0")  # older than pyproject's range
    del pins["pymunk"]
    problems = unsatisfied(_pyproject(), {"test"}, pins)
    assert problems == [
        "dependencies: 'pymunk>=6.6' is not in the lock",
        "dependencies: the lock pins numpy==1.20.0, outside 'numpy>=1.26'",
    ]
    assert unsatisfied(_pyproject(), {"gpu"}, pins) == [
        "the Makefile installs extra 'gpu', which pyproject.toml does not define"
    ]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("numpy>=1.26\n", "line 1: 'numpy>=1.26' is not an exact pin"),
        ("# header\nnumpy==2.0\nnumpy==2.1\n", "line 3: numpy is pinned twice"),
        ("numpy==2.*\n", "line 1: 'numpy==2.*' is not an exact pin"),
    ],
)
def test_a_lock_line_that_is_not_an_exact_pin_is_refused(text, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        read_lock(text)


def test_the_setup_targets_install_from_the_lock():
    makefile = _makefile()
    pip = re.search(r"^PIP := (.*)$", makefile, re.M)
    assert pip is not None
    # the packages, and the build backend of the package's isolated build
    assert 'PIP_CONSTRAINT="$(CURDIR)/$(LOCK)"' in pip[1]
    assert 'PIP_BUILD_CONSTRAINT="$(CURDIR)/$(LOCK)"' in pip[1]
    assert re.search(r"^LOCK := requirements\.lock$", makefile, re.M)
    installs = [line for line in makefile.splitlines() if re.search(r"\bpip\b.* install", line)]
    # Every install in the setup targets goes through $(PIP); only `make lock` resolves afresh.
    free = [line for line in installs if "$(PIP)" not in line and "$$tmp/venv" not in line]
    assert installs and free == []
