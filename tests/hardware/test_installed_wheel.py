"""``lfd-track hardware sim`` and ``hardware check`` from a normal install, outside the checkout.

The wheel is built from the checkout (offline, without build isolation) and installed with
``--no-deps`` into a fresh venv made for this test; its dependencies (numpy, pyserial, ...) come
from the test venv through a ``.pth`` file, which saves installing them again (a ``.pth`` file
in the added folder, such as the test venv's editable install of this checkout, is not
processed). Both commands run the venv's ``lfd-track`` script from a folder outside the
checkout, with an empty per-user cache, so the simulated board is built from the sources inside
the wheel.
"""

from __future__ import annotations

import importlib.util
import signal
import subprocess
import sysconfig
from pathlib import Path

import pytest
from lfd_test_support import offline_env, unavailable, wheel_in_fresh_venv

from lfd_track.hardware.simavr import HARDWARE_SOURCES, missing_tools

pytestmark = pytest.mark.simavr

REPO = Path(__file__).resolve().parents[2]
# Failure guards only: every wait returns as soon as the awaited output arrives.
BUILD_TIMEOUT_S = 120
RUN_TIMEOUT_S = 60


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """A fresh venv with the checkout's wheel installed; returns its ``bin`` folder."""
    missing = missing_tools()
    if missing:
        unavailable("the simulated board needs the AVR toolchain and simavr: " + "; ".join(missing))
    if importlib.util.find_spec("hatchling") is None:
        unavailable("the build backend hatchling is not installed (pip install hatchling)")
    root = tmp_path_factory.mktemp("installed")
    _, env_dir, site = wheel_in_fresh_venv(root, BUILD_TIMEOUT_S)
    deps = dict.fromkeys([sysconfig.get_path("purelib"), sysconfig.get_path("platlib")])
    (site / "_test_dependencies.pth").write_text("\n".join(deps) + "\n")
    return env_dir / "bin"


def test_hardware_sim_and_check_run_from_the_installed_wheel(installed: Path, tmp_path) -> None:
    workdir = tmp_path / "elsewhere"
    workdir.mkdir()
    cache = tmp_path / "cache"
    env = offline_env(XDG_CACHE_HOME=str(cache))
    where = subprocess.run(
        [str(installed / "python"), "-c",
         "import lfd_track.hardware.simavr as s; print(s.__file__); print(s.HARDWARE_DIR)"],
        check=True, capture_output=True, text=True, cwd=workdir, env=env,
    ).stdout.split()  # fmt: skip
    package_dir = installed.parent / "lib"
    assert all(Path(p).is_relative_to(package_dir) for p in where), where  # not the checkout

    sim = subprocess.Popen(
        [str(installed / "lfd-track"), "hardware", "sim"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=workdir, env=env,
    )  # fmt: skip
    try:
        lines: list[str] = []
        while not lines or not lines[-1].startswith("press Ctrl-C"):
            line = sim.stdout.readline()  # "" at once if the command died
            assert line, f"hardware sim ended early: {lines} {sim.communicate()[1]}"
            lines.append(line)
        url = lines[0].split("serial URL: ", 1)[1].split()[0]
        check = subprocess.run(
            [str(installed / "lfd-track"), "hardware", "check", "--serial", url, "--pings", "3"],
            capture_output=True, text=True, cwd=workdir, env=env, timeout=RUN_TIMEOUT_S,
        )  # fmt: skip
        assert check.returncode == 0, check.stdout + check.stderr
        # The version comes from the version query: no boot wait, no reset.
        assert "firmware version: 1.2 (last reset: power-on)" in check.stdout
        assert "OK: ping, e-stop latch" in check.stdout
        sim.send_signal(signal.SIGTERM)
        _, err = sim.communicate(timeout=RUN_TIMEOUT_S)
        assert sim.returncode == 0, err
    finally:
        if sim.poll() is None:
            sim.kill()
            sim.communicate()
    # Built in the per-user cache, keyed by the sources' hash; nothing next to the package.
    builds = list(cache.glob("lfd-track/simavr-*/firmware/lfd_rover.elf"))
    assert len(builds) == 1, builds
    assert list(cache.glob("lfd-track/simavr-*/sim/lfd_rover_sim"))
    shipped = Path(where[1])
    files = sorted(str(p.relative_to(shipped)) for p in shipped.rglob("*") if p.is_file())
    assert files == sorted(HARDWARE_SOURCES)
