"""``pip install lfd-track`` without extras: the env and the paper pipeline work, nothing more is
installed, and a feature of an extra names the ``pip install`` to run.

The wheel is built from the checkout (offline, without build isolation) and installed with
``--no-deps`` into a fresh venv. Its core dependencies, and theirs, are read from the wheel's
metadata (requirements without an ``extra`` marker) and copied, each distribution whole with its
``.dist-info``, from the test venv, which has them installed; no index is asked. ``pip check``
then proves the venv satisfies the wheel's requirements, and the venv holds no module of any
extra. The venv's size is printed (``-s`` shows it).
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import json
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from lfd_test_support import offline_env, unavailable, wheel_in_fresh_venv

from lfd_track.utils.extras import EXTRAS

pytestmark = pytest.mark.slow

TIMEOUT_S = 300  # failure guard only


def _name(text: str) -> str:
    return re.sub(r"[-_.]+", "-", text).lower()


def core_distributions(wheel: Path) -> list[importlib.metadata.Distribution]:
    """The wheel's requirements without extras, and theirs, as installed in the test venv."""
    from packaging.requirements import Requirement

    with zipfile.ZipFile(wheel) as zf:
        metadata = next(n for n in zf.namelist() if n.endswith(".dist-info/METADATA"))
        lines = zf.read(metadata).decode().splitlines()
    wanted = [line.split(":", 1)[1].strip() for line in lines if line.startswith("Requires-Dist:")]
    found: dict[str, importlib.metadata.Distribution] = {}
    while wanted:
        requirement = Requirement(wanted.pop())
        if requirement.marker is not None and not requirement.marker.evaluate({"extra": ""}):
            continue  # an extra's requirement, or not for this platform
        if _name(requirement.name) in found:
            continue
        dist = importlib.metadata.distribution(requirement.name)
        found[_name(requirement.name)] = dist
        wanted.extend(f"{r}" for r in dist.requires or [] if "extra ==" not in r or "; " not in r)
    return list(found.values())


def _copy_distribution(dist: importlib.metadata.Distribution, site: Path) -> None:
    for file in dist.files or []:
        if ".." in file.parts or file.parts[0] == "__pycache__" or "__pycache__" in file.parts:
            continue  # console scripts outside site-packages, byte code
        source = Path(dist.locate_file(file))
        if source.is_file():
            target = site / file
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target)


def _size(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file() and not p.is_symlink())


@pytest.fixture(scope="module")
def core_venv(tmp_path_factory) -> Path:
    """A fresh venv holding the wheel and its core dependencies only; returns its ``bin``."""
    if importlib.util.find_spec("hatchling") is None:
        unavailable("the build backend hatchling is not installed (pip install hatchling)")
    root = tmp_path_factory.mktemp("core")
    wheel, env_dir, site = wheel_in_fresh_venv(root, TIMEOUT_S)
    for dist in core_distributions(wheel):
        _copy_distribution(dist, site)
    print(f"\ncore venv: {_size(env_dir) / 2**20:.0f} MiB ({env_dir})")
    return env_dir / "bin"


def test_the_core_venv_satisfies_the_wheel_and_holds_no_extra(core_venv):
    check = subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(core_venv / "python"), "check"],
        capture_output=True, text=True, env=offline_env(), timeout=TIMEOUT_S,
    )  # fmt: skip
    assert check.returncode == 0, check.stdout + check.stderr
    modules = sorted({m for _, names in EXTRAS.values() for m in names})
    probe = f"import importlib.util; print([m for m in {modules!r} if importlib.util.find_spec(m)])"
    found = subprocess.run(
        [str(core_venv / "python"), "-c", probe],
        check=True, capture_output=True, text=True, env=offline_env(), timeout=TIMEOUT_S,
    ).stdout.strip()  # fmt: skip
    assert found == "[]"


def test_the_env_and_the_quick_benchmark_run_in_the_core_venv(core_venv, tmp_path):
    code = (
        "import gymnasium as gym\n"
        "import lfd_track  # registers the envs\n"
        "env = gym.make('LfDTrack-v0')\n"
        "obs, info = env.reset(seed=0)\n"
        "obs, *_ = env.step(0)\n"
        "print(obs.shape)\n"
    )
    made = subprocess.run(
        [str(core_venv / "python"), "-c", code],
        capture_output=True, text=True, cwd=tmp_path, env=offline_env(), timeout=TIMEOUT_S,
    )  # fmt: skip
    assert made.returncode == 0, made.stderr
    assert made.stdout.strip() == "(480, 640, 3)"
    out = tmp_path / "quick"
    bench = subprocess.run(
        [str(core_venv / "lfd-track"), "benchmark", "--quick", "--out", str(out)],
        capture_output=True, text=True, cwd=tmp_path, env=offline_env(), timeout=TIMEOUT_S,
    )  # fmt: skip
    assert bench.returncode == 0, bench.stderr
    assert json.loads((out / "results.json").read_text())
    assert (out / "report.md").is_file()


def test_a_feature_of_an_extra_names_it_in_the_core_venv(core_venv, tmp_path):
    teach = subprocess.run(
        [str(core_venv / "lfd-track"), "teach", "--out", str(tmp_path / "x.lfdemo")],
        capture_output=True, text=True, cwd=tmp_path, env=offline_env(), timeout=TIMEOUT_S,
    )  # fmt: skip
    assert teach.returncode != 0
    assert teach.stderr.strip().splitlines() == [
        "lfd-track teach: the teaching station (lfd-track teach) needs the web extra:"
        " pip install 'lfd-track[web]'"
    ]
