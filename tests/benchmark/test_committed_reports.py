"""The committed example reports are what the current code draws from their results.json,
read (and migrated from older schemas) as every reader reads it."""

from __future__ import annotations

from pathlib import Path

import pytest

from lfd_track.benchmark.report import write_report_from_results
from lfd_track.benchmark.schema import read_results

# Every results folder of the lab notebook (benchmarks/experiments/<question>/.../results/).
RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "experiments"
FOLDERS = sorted(
    str(p.parent.relative_to(RESULTS))
    for p in RESULTS.rglob("results.json")
    if (p.parent / "report.md").is_file()
)


def test_there_are_committed_runs():
    assert {"paper_protocol/results/seed0", "paper_protocol/results/careless"} <= set(FOLDERS)
    assert len(FOLDERS) == 722  # every study job and benchmark run committed


@pytest.mark.parametrize("folder", FOLDERS)
def test_committed_report_matches_its_results(folder, tmp_path):
    results = read_results(RESULTS / folder / "results.json")
    written = write_report_from_results(tmp_path, results).read_text(encoding="utf-8")
    assert written == (RESULTS / folder / "report.md").read_text(encoding="utf-8")
