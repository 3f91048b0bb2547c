"""What a result was computed with: the versions and the BLAS kernel, recorded beside results.

Every ``results.json`` of a benchmark, every ``study.json`` and every speed-benchmark result
records :func:`environment`. The same seed on the same machine with the same versions gives the
same bytes; another BLAS kernel (another CPU, another ``OPENBLAS_CORETYPE``) may change the last
bits of the floating-point numbers (fitness values, network outputs) but not the commands and
outcomes (README, section on what the same seed reproduces). These fields say which case a
comparison is.
"""

from __future__ import annotations

import os
import platform
from typing import Any

#: Fields of one BLAS library as threadpoolctl reports it (``architecture`` is OpenBLAS's core
#: name, e.g. "Haswell"; other BLAS libraries leave it out).
_BLAS_FIELDS = ("internal_api", "version", "architecture", "threading_layer", "num_threads")


def blas_libraries() -> list[dict[str, Any]] | None:
    """The BLAS libraries loaded in this process (numpy's, once numpy is imported), each with
    its kernel ("architecture") and thread count, from threadpoolctl's ``threadpool_info()``;
    None where threadpoolctl is not installed (a dependency, but a missing one does not stop a
    run from writing its results)."""
    import numpy  # noqa: F401  (loads numpy's BLAS, so that threadpoolctl finds it)

    try:
        from threadpoolctl import threadpool_info
    except ImportError:
        return None
    # OpenCV's wheel bundles an OpenBLAS of its own; the file name tells the two apart. Sorted by
    # it, since the order threadpoolctl finds them in follows the order they were loaded.
    found = [
        {
            "library": os.path.basename(info.get("filepath") or ""),
            **{k: info.get(k) for k in _BLAS_FIELDS},
        }
        for info in threadpool_info()
        if info.get("user_api") == "blas"
    ]
    return sorted(found, key=lambda entry: entry["library"])


def environment() -> dict[str, Any]:
    """Versions of Python and of the libraries that compute results, the CPU, and the BLAS
    kernel in use, as a JSON-ready dict (the ``environment`` field of the results files)."""
    import cv2
    import gymnasium
    import numpy
    import pymunk

    from .. import __version__

    return {
        "lfd_track": __version__,
        "python": platform.python_version(),
        "processor": platform.machine(),
        "cpus": os.cpu_count(),
        "numpy": numpy.__version__,
        "opencv": cv2.__version__,
        "pymunk": pymunk.version,
        "gymnasium": gymnasium.__version__,
        "blas": blas_libraries(),
        # OPENBLAS_CORETYPE chooses the kernel; the thread settings are what the BLAS was told.
        "openblas_env": {k: v for k, v in sorted(os.environ.items()) if k.startswith("OPENBLAS_")},
    }
