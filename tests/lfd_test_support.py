"""Helpers the test folders share (importable everywhere: tests/conftest.py puts this folder on
the path)."""

from __future__ import annotations

import functools
import importlib.util
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

if TYPE_CHECKING:
    from lfd_track.vision.road_library import RoadLibrary

#: The tests folder, the repository it belongs to, and the committed test files (``tests/data``).
TESTS = Path(__file__).resolve().parent
REPO = TESTS.parent
TEST_DATA = TESTS / "data"


def unavailable(message: str) -> None:
    """Skip the test for a missing tool, except under CI=true, where a missing tool fails it."""
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(f"{message} (CI=true, so this is a failure, not a skip)", pytrace=False)
    pytest.skip(message)


def load_test_module(path: Path, alias: str) -> ModuleType:
    """The test module at ``path`` (its fakes and helpers), loaded once under ``alias``.

    Test folders are not packages, so a module of another folder is loaded by path.
    """
    if alias not in sys.modules:
        spec = importlib.util.spec_from_file_location(alias, path)
        assert spec is not None and spec.loader is not None, path
        module = importlib.util.module_from_spec(spec)
        sys.modules[alias] = module
        spec.loader.exec_module(module)
    return sys.modules[alias]


@functools.cache
def training_track_frame() -> np.ndarray:
    """A camera frame on the training track's felt (seed 1), rendered once per process."""
    from lfd_track.envs.track_env import LfDTrackEnv

    env = LfDTrackEnv(track="training")
    frame, _ = env.reset(seed=1)
    env.close()
    return frame


def library_with_road() -> tuple[RoadLibrary, np.ndarray]:
    """A fresh road library that learned :func:`training_track_frame`, and that frame."""
    from lfd_track.vision.road_library import RoadLibrary

    library = RoadLibrary()
    frame = training_track_frame()
    library.learn(frame)
    return library, frame


def snapshot(folder: Path) -> dict[str, tuple[bytes | None, int]]:
    """Every entry below ``folder``: a file's (contents, modification time), (None, 0) for a
    folder (whose time changes when entries are moved in and back out)."""
    return {
        str(p.relative_to(folder)): (p.read_bytes(), p.stat().st_mtime_ns)
        if p.is_file()
        else (None, 0)
        for p in sorted(folder.rglob("*"))
    }


def one_line(err: str) -> str:
    """``err`` (a command's stderr), asserted to be one line and no traceback."""
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


def no_space_for(path: Path) -> Callable[[Any, Any], Any]:
    """An ``os.replace`` that fails with a full disk when moving a file to ``path`` (monkeypatch
    it in), and moves every other file as the real one does."""
    real = os.replace

    def replace(src: Any, dst: Any) -> Any:
        if Path(dst) == path:
            raise OSError(28, "No space left on device", str(dst))
        return real(src, dst)

    return replace


def interrupt_demo_after(
    monkeypatch: pytest.MonkeyPatch, commands: int, signum: int, *, fsync: bool | None = None
) -> None:
    """Make the next ``lfd-track demo`` receive ``signum`` (a real signal) after ``commands``
    commands; ``fsync=False`` also skips its fsyncs (fast)."""
    from lfd_track.demo import demonstrator

    real = demonstrator.run_demonstration

    def run(*args, progress=None, **kwargs):
        def tick(n: int) -> None:
            if progress is not None:
                progress(n)
            if n == commands:
                os.kill(os.getpid(), signum)

        if fsync is not None:
            kwargs["fsync"] = fsync
        return real(*args, progress=tick, **kwargs)

    monkeypatch.setattr(demonstrator, "run_demonstration", run)


def wait_until(
    condition: Callable[[], Any], what: str, timeout_s: float = 15.0, poll_s: float = 0.01
) -> Any:
    """Poll ``condition`` until it is truthy and return its value; fail naming ``what`` after
    ``timeout_s`` (a failure guard only: every wait returns as soon as its condition holds)."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(poll_s)


#: Where the results that pass through BLAS (matrix products, whose last bits depend on the
#: OpenBLAS kernel and so on the CPU) leave the package: the GA's stacked network outputs, every
#: network forward pass (the fitness module's own, and each policy's ``ensemble_forward``:
#: training accuracy, controllers, commanders), and the road-value correlations of the road
#: library.
BLAS_RESULTS = (
    ("lfd_track.learning.fitness", "population_outputs"),
    ("lfd_track.learning.fitness", "mlp_forward"),
    ("lfd_track.learning.fitness", "ensemble_forward"),
    ("lfd_track.policy.controller", "ensemble_forward"),
    ("lfd_track.teaching.commanders", "ensemble_forward"),
    ("lfd_track.vision.road_library", "similarity_matrix"),
)


def nudge_last_bits(values: Any, rng: np.random.Generator, ulps: int) -> np.ndarray:
    """``values`` with each element moved 1 to ``ulps`` floating-point steps, up or down at
    random; exact 0 and ±1 stay (they are set, not summed: flat-histogram correlations,
    saturated sigmoids)."""
    a = np.asarray(values, dtype=np.float64)
    steps = rng.integers(1, ulps + 1, size=a.shape)
    toward = np.where(rng.random(a.shape) < 0.5, np.inf, -np.inf)
    fixed = (a == 0.0) | (np.abs(a) == 1.0)
    out = a.copy()
    for k in range(ulps):
        out = np.where((steps > k) & ~fixed, np.nextafter(out, toward), out)
    return out


class PerturbedBLAS:
    """Context manager: every result in :data:`BLAS_RESULTS` comes back moved by a few ulps
    (:func:`nudge_last_bits`, one seeded stream), as another BLAS kernel could round it.

    ``calls`` counts the perturbed results per patched name, so a test can check that the
    patches were reached.
    """

    def __init__(self, seed: int, ulps: int = 4):
        self.rng = np.random.default_rng(seed)
        self.ulps = ulps
        self.calls: dict[str, int] = {}
        self._saved: list[tuple[ModuleType, str, Any]] = []

    def __enter__(self) -> PerturbedBLAS:
        import importlib

        try:
            for module_name, name in BLAS_RESULTS:
                module = importlib.import_module(module_name)
                original = getattr(module, name)
                self._saved.append((module, name, original))
                setattr(module, name, self._wrap(f"{module_name}.{name}", original))
        except BaseException:
            self.__exit__()  # a missing name: put back what was patched, then fail
            raise
        return self

    def _wrap(self, key: str, original: Callable[..., Any]) -> Callable[..., Any]:
        def perturbed(*args: Any, **kwargs: Any) -> np.ndarray:
            self.calls[key] = self.calls.get(key, 0) + 1
            return nudge_last_bits(original(*args, **kwargs), self.rng, self.ulps)

        return perturbed

    def __exit__(self, *exc: object) -> None:
        for module, name, original in reversed(self._saved):
            setattr(module, name, original)
        self._saved.clear()


def offline_env(**extra: str) -> dict[str, str]:
    """This process's environment for a pip or a fresh venv's Python that must not reach an index
    nor see this venv's Python settings (``extra`` added on top)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "VIRTUAL_ENV"))}
    env.update(PIP_NO_INDEX="1", PIP_DISABLE_PIP_VERSION_CHECK="1", PYTHONNOUSERSITE="1")
    env.update(extra)
    return env


def wheel_in_fresh_venv(root: Path, timeout_s: float) -> tuple[Path, Path, Path]:
    """Build the checkout's wheel into ``root/wheel`` (no build isolation, no index) and install
    it alone (``--no-deps``) into a new venv at ``root/venv``.

    Returns ``(wheel, venv folder, the venv's site-packages)``; the caller supplies the
    dependencies. ``timeout_s`` guards each pip call against a hang only.
    """
    import subprocess
    import venv

    repo = REPO
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index",
         "--quiet", "-w", str(root / "wheel"), str(repo)],
        check=True, env=offline_env(), timeout=timeout_s,
    )  # fmt: skip
    (wheel,) = (root / "wheel").glob("lfd_track-*.whl")
    env_dir = root / "venv"
    venv.create(env_dir, with_pip=False, clear=True)
    python = env_dir / "bin" / "python"
    subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps",
         "--no-index", "--quiet", str(wheel)],
        check=True, env=offline_env(), timeout=timeout_s,
    )  # fmt: skip
    site = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
        check=True, capture_output=True, text=True, env=offline_env(), timeout=timeout_s,
    ).stdout.strip()  # fmt: skip
    return wheel, env_dir, Path(site)


# ------------------------------------------------------- a learned controller's stand-in
class _Forward:
    """Commander that always drives forward."""

    def reset(self) -> None:
        pass

    def propose(self, moment: Any) -> Any:
        from lfd_track.core.commands import Command

        return Command.FORWARD


class ForwardController:
    """Stand-in for a learned controller: drives forward until the trial ends."""

    learn = False

    def perception(self) -> Any:
        from lfd_track.teaching.perception import Perception
        from lfd_track.vision.road_library import RoadLibrary

        return Perception(RoadLibrary(), "always")

    def commander(self) -> _Forward:
        return _Forward()

    def save(self, path: str | Path) -> None:
        Path(path).write_text("{}\n", encoding="utf-8")


def stand_in_learned() -> Any:
    """What a repetition's learning returns, with :class:`ForwardController` as its controller."""
    from lfd_track.methods.common import Learned, effort_record

    return Learned(
        controller=ForwardController(),  # type: ignore[arg-type]
        demo={
            "cases": 150,
            "counts": {"forward": 120, "left": 15, "right": 15},
            "turnarounds": ["left", "right"],
            "library_models": 40,
            "library_types": 2,
            "learned_off_felt": 0,
        },
        fitness_best=[0.5, 0.4],
        fitness_mean=[0.6, 0.5],
        training_accuracy=0.8,
        effort=effort_record(0.4, demonstration_commands=160),
    )
