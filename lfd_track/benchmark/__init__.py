"""The corner-success benchmark of the paper (§4.2.5, §5): counting, tables and reports.

``tables`` turns trial outcomes into the paper's Tables 2 and 3 (ours beside the paper's numbers,
which live in ``paper``) and writes ``results.json`` and ``report.md``.
"""

from __future__ import annotations

from .paper import paper_results
from .tables import (
    FAILURE_KINDS,
    TrialOutcome,
    build_results,
    format_tables,
    results_json_text,
    write_report,
    write_results_json,
)

__all__ = [
    "FAILURE_KINDS",
    "TrialOutcome",
    "build_results",
    "format_tables",
    "paper_results",
    "results_json_text",
    "write_report",
    "write_results_json",
]
