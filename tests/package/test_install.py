"""The built wheel carries its data: installed outside the checkout, ``gym.make`` works anywhere.

Network-free stand-in for "``pip install .`` into a fresh venv, then ``gym.make("LfDTrack-v0")``
from an unrelated directory": the wheel is built from the checkout without build isolation,
installed with ``--no-deps --no-index --target`` into a temporary folder, and used from a child
interpreter that cannot see the checkout. The venv's editable install puts the checkout on
``sys.path`` through a ``.pth`` file, so the child runs with ``-I -S`` (no cwd, no site
processing) and gets only the temporary folder and the venv's plain site-packages folders.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest
from lfd_test_support import REPO, unavailable

DATA_FILES = (
    "lfd_track/_data/tracks/testing.toml",
    "lfd_track/_data/tracks/training.toml",
    "lfd_track/_data/tracks/notch.toml",
    "lfd_track/_data/tracks/bolt.toml",
    "lfd_track/_data/tracks/step.toml",
    "lfd_track/_data/envs/paper.toml",
    "lfd_track/_data/envs/randomized.toml",
    "lfd_track/_data/envs/wide.toml",
    "lfd_track/_data/samples/demonstrations.zip",  # lfd-track sample-data
    "lfd_track/web/static/index.html",  # the teaching station's page ships in the package
    "lfd_track/web/static/app.js",
    "lfd_track/web/static/style.css",
)

# Runs in the child. argv: site folder of the installed wheel, the checkout, then the venv's
# site-packages folders (with -S the child does not know it runs in a venv).
CHILD = r"""
import importlib.util, json, sys
from pathlib import Path

site, repo = Path(sys.argv[1]).resolve(), Path(sys.argv[2]).resolve()
visible_before = importlib.util.find_spec("lfd_track") is not None
sys.path[:0] = [str(site)] + [p for p in dict.fromkeys(sys.argv[3:]) if p not in sys.path]
leaks = [p for p in sys.path if p in ("", ".") or Path(p).resolve() == repo]

import gymnasium as gym
import numpy as np

env = gym.make("lfd_track:LfDTrack-v0")  # the "module:id" form imports the package itself
obs, info = env.reset(seed=0)
for action in (0, 1, 2, 0):
    obs, reward, terminated, truncated, info = env.step(action)

import lfd_track
from lfd_track.hardware import simavr
from lfd_track.utils.data import data_dir

other = gym.make("LfDTrack-v0", track="training", reverse=True, preset="randomized")
other_obs, _ = other.reset(seed=1)
print(json.dumps({
    "visible_before": visible_before,
    "leaks": leaks,
    "package_file": str(Path(lfd_track.__file__).resolve()),
    "tracks_dir": str(data_dir("tracks").resolve()),
    "envs_dir": str(data_dir("envs").resolve()),
    "hardware_dir": str(simavr.HARDWARE_DIR.resolve()),
    "obs_shape": list(obs.shape),
    "obs_dtype": str(obs.dtype),
    "obs_std": float(obs.std()),
    "steps": info["step"],
    "other_obs_shape": list(other_obs.shape),
}))
"""


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """Build the wheel of the checkout, offline, into a temporary folder."""
    if importlib.util.find_spec("hatchling") is None:
        unavailable("the build backend hatchling is not installed (pip install hatchling)")
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
         "--no-index", "--quiet", "-w", str(out), str(REPO)],
        check=True, env=_offline_env(), timeout=120,
    )  # fmt: skip
    wheels = list(out.glob("lfd_track-*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


def _offline_env() -> dict[str, str]:
    env = dict(os.environ)
    env.update(PIP_NO_INDEX="1", PIP_DISABLE_PIP_VERSION_CHECK="1", PYTHONNOUSERSITE="1")
    return env


def test_wheel_carries_tracks_envs_and_the_cli(wheel):
    with zipfile.ZipFile(wheel) as zf:
        names = set(zf.namelist())
        entry_points = next(
            zf.read(n).decode() for n in names if n.endswith(".dist-info/entry_points.txt")
        )
    missing = [f for f in DATA_FILES if f not in names]
    assert not missing, f"wheel lacks {missing}"
    assert "lfd_track/__init__.py" in names and "lfd_track/envs/track_env.py" in names
    assert "lfd_track/py.typed" in names  # the package's type hints ship with it (PEP 561)
    # Nothing from the checkout's other top-level folders rides along.
    assert not [n for n in names if n.startswith(("tests/", "benchmarks/", "hardware/", "tracks/"))]
    assert "lfd-track = lfd_track.cli:main" in entry_points


def test_installed_wheel_makes_the_env_from_an_unrelated_directory(wheel, tmp_path):
    site = tmp_path / "site"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--no-index", "--quiet",
         "--target", str(site), str(wheel)],
        check=True, env=_offline_env(), timeout=120,
    )  # fmt: skip
    workdir = tmp_path / "elsewhere"
    workdir.mkdir()
    env = {k: v for k, v in _offline_env().items() if not k.startswith("PYTHON")}
    proc = subprocess.run(
        [sys.executable, "-I", "-S", "-c", CHILD, str(site), str(REPO),
         sysconfig.get_path("purelib"), sysconfig.get_path("platlib")],
        cwd=workdir, env=env, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout.strip().splitlines()[-1])

    site = site.resolve()
    assert report["visible_before"] is False, "the checkout is importable in the child"
    assert report["leaks"] == []
    assert Path(report["package_file"]).is_relative_to(site)
    assert Path(report["tracks_dir"]) == site / "lfd_track" / "_data" / "tracks"
    assert Path(report["envs_dir"]) == site / "lfd_track" / "_data" / "envs"
    assert Path(report["hardware_dir"]) == site / "lfd_track" / "_data" / "hardware"
    assert report["obs_shape"] == [480, 640, 3] and report["obs_dtype"] == "uint8"
    assert report["obs_std"] > 1.0  # a rendered picture, not a blank frame
    assert report["steps"] == 4
    assert report["other_obs_shape"] == [480, 640, 3]


def test_checkout_finds_its_data_through_the_same_lookup():
    from lfd_track.hardware import simavr
    from lfd_track.utils.data import data_dir

    assert data_dir("tracks") == REPO / "tracks"
    assert data_dir("envs") == REPO / "envs"
    assert simavr.HARDWARE_DIR == data_dir("hardware", required=simavr.HARDWARE_SOURCES)
    assert simavr.HARDWARE_DIR == REPO / "hardware"
    with pytest.raises(FileNotFoundError, match="'hardware' not found"):
        data_dir("hardware", required=["no/such/file.c"])
