"""A feature whose extra is not installed fails in one line naming the ``pip install`` to run.

Each case runs in a child interpreter where the extra's modules are made unimportable with
``sys.modules[name] = None`` (what Python does for a module known to be absent), so the test
venv, which has every extra, stands in for a core install.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from lfd_test_support import REPO

from lfd_track.utils.extras import EXTRAS, MissingExtraError, install_line, needs_extra

ALL_EXTRA_MODULES = sorted({m for _, modules in EXTRAS.values() for m in modules})

CHILD = r"""
import sys
for name in sys.argv[1].split(","):
    sys.modules[name] = None
sys.path.insert(0, sys.argv[2])
exec(sys.argv[3])
"""


def _run(block: list[str], code: str, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", CHILD, ",".join(block), str(REPO), code],
        capture_output=True, text=True, cwd=tmp_path, timeout=300,
    )  # fmt: skip


def _cli(args: list[str]) -> str:
    return f"from lfd_track.cli import main; sys.exit(main({args!r}))"


@pytest.mark.parametrize(
    ("blocked", "args", "extra"),
    [
        (["starlette"], ["teach", "--out", "x.lfdemo"], "web"),
        (["uvicorn"], ["teach", "--out", "x.lfdemo"], "web"),
        (["serial"], ["hardware", "check", "--serial", "loop://"], "hardware"),
    ],
)
def test_the_cli_names_the_missing_extra_in_one_line(tmp_path, blocked, args, extra):
    proc = _run(blocked, _cli(args), tmp_path)
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].endswith(f"pip install 'lfd-track[{extra}]'"), lines[0]
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "x.lfdemo").exists()


@pytest.mark.parametrize(
    ("blocked", "code", "extra"),
    [
        (["serial"], "import lfd_track.hardware.link", "hardware"),
        (["websockets"], "import lfd_track.web.server", "web"),
        (
            ["cma"],
            "import numpy as np\nfrom lfd_track.learning.cmaes import fit_cmaes\n"
            "fit_cmaes(np.zeros((3, 40)), np.zeros(3, int), None, np.random.default_rng(0))",
            "cmaes",
        ),
        (
            ["imageio_ffmpeg"],
            "import numpy as np, gymnasium as gym\nimport lfd_track\n"
            "from lfd_track.viz.video import DriveVideo\n"
            "env = gym.make('LfDTrack-v0'); obs, info = env.reset(seed=0)\n"
            "DriveVideo('v.mp4', env.unwrapped).add(obs, np.zeros(40), info)",
            "video",
        ),
    ],
)
def test_importing_a_feature_without_its_extra_raises_one_line(tmp_path, blocked, code, extra):
    wrapped = f"try:\n    exec({code!r})\nexcept ImportError as exc:\n    print(type(exc).__name__, exc)\n"
    proc = _run(blocked, wrapped, tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == f"MissingExtraError {install_line(extra)}"


def test_the_env_and_the_paper_pipeline_need_no_extra(tmp_path):
    code = (
        "import gymnasium as gym, lfd_track\n"
        "env = gym.make('LfDTrack-v0'); env.reset(seed=0); env.step(0)\n"
        "from lfd_track import methods\n"
        "from lfd_track.benchmark import runner\n"
        "from lfd_track.learning import ga, fitness\n"
        "from lfd_track.study import run\n"
        "print('ok')\n"
    )
    proc = _run(ALL_EXTRA_MODULES, code, tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "ok"


def test_an_import_error_inside_an_installed_extra_is_not_hidden():
    with pytest.raises(ModuleNotFoundError, match="no_such_module"):
        with needs_extra("web"):
            import no_such_module  # noqa: F401
    with pytest.raises(MissingExtraError, match=r"pip install 'lfd-track\[web\]'"):
        with needs_extra("web"):
            raise ModuleNotFoundError(
                "No module named 'uvicorn.protocols'", name="uvicorn.protocols"
            )
