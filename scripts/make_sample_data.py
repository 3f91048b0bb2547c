"""Write samples/demonstrations.zip: the demonstrations `lfd-track sample-data` unpacks.

Three scripted-human demonstrations (seeds 0, 1 and 2) of one end-to-end drive of the training
track (right end to left end, ``HumanConfig(legs=1)``), each with its own road library of 8 bins
per channel instead of the paper's 32, which keeps the three recordings (their region histograms
above all) to about 300 KB compressed. Run from the repository root:

    python scripts/make_sample_data.py
"""

from __future__ import annotations

import tempfile
import zipfile
from pathlib import Path

from lfd_track.demo.demonstrator import HumanConfig, run_demonstration
from lfd_track.vision.road_library import RoadLibrary

SEEDS = (0, 1, 2)
BINS = 8
OUT = Path("samples/demonstrations.zip")


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        names = []
        for seed in SEEDS:
            path = Path(tmp) / f"training-{seed}.lfdemo"
            summary = run_demonstration(
                path,
                seed=seed,
                track="training",
                human=HumanConfig(legs=1),
                library_factory=lambda: RoadLibrary(bins=BINS),
                fsync=False,
            )
            print(f"{path.name}: {summary.n_cases} cases, {summary.counts}")
            names.append(path)
        OUT.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(OUT, "w", compression=zipfile.ZIP_LZMA) as archive:
            for path in names:
                # A fixed date: the same recordings give the same archive.
                info = zipfile.ZipInfo(path.name, date_time=(2024, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_LZMA
                archive.writestr(info, path.read_bytes())
    print(f"{OUT}: {OUT.stat().st_size} bytes")


if __name__ == "__main__":
    main()
