"""The report of an evaluation: success rates with Wilson 95 % intervals (``rates`` of its
results.json and their table) and report.md."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..study.stats import rate_summary
from .paper import DIRECTION_TITLES
from .paper import DIRECTIONS as TABLE_DIRECTIONS
from .tables import LOOP_DIRECTIONS, TrialOutcome

__all__ = ["ours_cell", "rates_section", "success_rates", "write_evaluation_report"]


def ours_cell(results: Mapping[str, Any]) -> str:
    info = results.get("evaluation", {})
    laps = info.get("laps", "?")
    return (
        f"policy `{info.get('policy', '?')}` on {info.get('observation', '?')},"
        f" {laps} per direction, seed {results.get('seed', '?')}"
    )


def success_rates(outcomes: Sequence[TrialOutcome], tracks: Sequence[str]) -> dict[str, Any]:
    """Successes, trials, rate and Wilson 95 % interval per track and direction, and overall."""
    rates: dict[str, Any] = {}
    for track in tracks:
        directions = TABLE_DIRECTIONS.get(track, LOOP_DIRECTIONS)
        runs = [o for o in outcomes if o.track == track]
        section = {
            d: rate_summary(sum(o.success for o in ds), len(ds))
            for d in directions
            for ds in [[o for o in runs if o.direction == d]]
        }
        section["all"] = rate_summary(sum(o.success for o in runs), len(runs))
        rates[track] = section
    rates["all"] = rate_summary(sum(o.success for o in outcomes), len(outcomes))
    return rates


def _interval(rate: Mapping[str, Any]) -> str:
    if not rate["trials"]:
        return "n/a"
    low, high = rate["ci95"]
    return (
        f"{rate['successes']}/{rate['trials']} = {100 * rate['rate']:.1f} %"
        f" [{100 * low:.1f}, {100 * high:.1f}]"
    )


def rates_section(results: Mapping[str, Any]) -> str:
    """Markdown table of the success rates with their Wilson 95 % intervals."""
    rates = results["rates"]
    lines = [
        "## Success rates with Wilson 95 % intervals",
        "",
        "| track | direction | successes/runs = rate [95 % interval, %] |",
        "|---|---|---|",
    ]
    for track, section in rates.items():
        if track == "all":
            continue
        # results.json sorts its keys: the table keeps the report's order.
        for direction in (*TABLE_DIRECTIONS.get(track, LOOP_DIRECTIONS), "all"):
            title = "all" if direction == "all" else DIRECTION_TITLES[direction].lower()
            lines.append(f"| {track} | {title} | {_interval(section[direction])} |")
    lines += [
        f"| every track | all | {_interval(rates['all'])} |",
        "",
        "The intervals treat every run as independent; runs of one direction share their floor.",
        "",
    ]
    return "\n".join(lines)


def write_evaluation_report(out: str | Path, results: Mapping[str, Any]) -> Path:
    """Write ``out/report.md`` from an evaluation's results.json dict."""
    from .report import test_tracks_section
    from .tables import write_report

    info = results["evaluation"]
    laps = info["laps"]
    runs = "run" if laps == 1 else "runs"
    intro = (
        f"The paper's protocol (§4.2.5) on policy `{info['policy']}`, which reads"
        f" {info['observation']}: {laps} {runs} in each direction on every track it drove"
        f" ({', '.join(info['tracks'])})"
    )
    intro += (
        "; laps of the testing track start at corner 4." if "testing" in info["tracks"] else "."
    )
    intro += " Nothing is learned: the policy is scored as it is."
    if info.get("library"):
        intro += f" Road values from the road library of `{info['library']}`."
    extra = [rates_section(results)]
    if results.get("test_tracks"):
        extra.append(test_tracks_section(results["test_tracks"]))
    return write_report(
        out,
        results,
        extra_sections=extra,
        title="Corner-success evaluation",
        intro=intro,
        ours=ours_cell(results),
    )
