"""Every results file names what computed it: versions and the BLAS kernel (lfd_track.utils.provenance)."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys

import cv2
import gymnasium
import numpy as np
import pymunk
import pytest

from lfd_track.utils.provenance import blas_libraries, environment


def test_the_environment_names_the_versions_and_the_blas_kernel():
    env = environment()
    assert env["python"] == platform.python_version()
    assert (env["numpy"], env["opencv"]) == (np.__version__, cv2.__version__)
    assert (env["pymunk"], env["gymnasium"]) == (pymunk.version, gymnasium.__version__)
    assert env["blas"], "threadpoolctl found no BLAS library (is it installed?)"
    for lib in env["blas"]:
        assert set(lib) == {
            "library",
            "internal_api",
            "version",
            "architecture",
            "threading_layer",
            "num_threads",
        }
        assert lib["library"] and lib["num_threads"] >= 1
    assert json.loads(json.dumps(env)) == env  # JSON-ready as it is


@pytest.mark.skipif(platform.machine() != "x86_64", reason="OpenBLAS x86-64 kernel names")
def test_the_kernel_recorded_is_the_one_running():
    """OPENBLAS_CORETYPE picks the kernel; the record follows it (Nehalem runs on every x86-64
    CPU with SSE4.2, which numpy 2 requires anyway)."""
    libraries = blas_libraries()
    assert libraries is not None, "threadpoolctl, a dependency, is not installed"
    if not any(lib["internal_api"] == "openblas" for lib in libraries):
        pytest.skip("numpy does not use OpenBLAS here")
    code = "import json; from lfd_track.utils.provenance import environment; print(json.dumps(environment()))"
    env = {**os.environ, "OPENBLAS_CORETYPE": "Nehalem", "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    recorded = json.loads(proc.stdout)
    numpy_blas = [lib for lib in recorded["blas"] if lib["internal_api"] == "openblas"]
    assert numpy_blas and all(lib["architecture"] == "Nehalem" for lib in numpy_blas)
    assert all(lib["num_threads"] == 1 for lib in numpy_blas)
    # Every OPENBLAS_ variable of the process is recorded: the two set here, and any other the
    # machine sets (e.g. OPENBLAS_L2_SIZE), as they are.
    assert recorded["openblas_env"] == {k: v for k, v in env.items() if k.startswith("OPENBLAS_")}
    assert recorded["openblas_env"]["OPENBLAS_CORETYPE"] == "Nehalem"


def test_without_threadpoolctl_the_blas_is_unknown_but_results_are_written(monkeypatch):
    monkeypatch.setitem(sys.modules, "threadpoolctl", None)  # import fails
    env = environment()
    assert env["blas"] is None and env["numpy"] == np.__version__
