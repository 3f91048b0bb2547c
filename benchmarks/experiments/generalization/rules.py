"""The hand-written rules' rows of the generalization table: rules that learn nothing, scored on
the very loops, worlds and testing-track laps of the study's jobs.

For every seed and repetition of the study file, the repetition's own streams
(``lfd_track.benchmark.runner.repetition_streams``) give its demonstration seed and its trial
seed, exactly as the study's ``paper`` condition uses them. The paper's demonstration with that
seed builds the road library (frozen while driving); then each rule drives the repetition's
trials: the named test tracks ``trials_per_direction`` times each way, and the repetition's
procedural loops, admitted by the same teacher's check (``run_loop_trials``).

* ``road-rule``: the road-value rule chosen by the limits experiment (part 2, ``latch.t1.5.flat``:
  aim at the felt's mean column, pivot beyond 1.5 columns, on a blank view toward the last bend);
  it reads the 40 road values, as the paper's network does.
* ``map-rule``: the fresh-felt rule on the shipped ``fresh_felt`` map (the goal's chosen map),
  pivoting toward fresh felt beyond the picture-steering human's 20°: the very rule the chosen
  configuration's network is fitted to, on the network's own inputs.

Writes ``results/rules/<rule>/seed<k>/results.json`` (the benchmark's format) and
``results/rules/rules.md``.

    .venv/bin/python benchmarks/experiments/generalization/rules.py --workers 2

The map rule's map assumes the paper's constants (its camera, 0.10 m and 22.9° per command)
whatever the preset, where a learned controller's map takes its world's (for the paper world
22.918° per pivot, the only difference); with another preset use
``../sharp_corners/run_rules.py``, which gives the map the preset's geometry. A condition with
``room = "per_repetition"`` is driven as its jobs are: each repetition in its own room
(``repetition_preset``), the road library of the paper's demonstration in that room, the map
with that room's camera and motion.

``--rule NAME`` scores only that rule (repeatable); ``--map KEY=VALUE`` (repeatable) drives the
map rule on its map with that setting changed (e.g. ``--map path_radius_m=0.2``).
``--study FILE --condition NAME --out DIR`` scores the rules on another study's trials instead
(that condition's tracks, loops and preset, the study's seeds), ``--repetitions N`` on the first
N repetitions of each seed (the same repetitions as the study's first N: a repetition's seed does
not depend on how many follow). ``rules.md`` then also pools the named tracks other than the
testing track.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from lfd_track.benchmark.config import BenchmarkConfig
from lfd_track.benchmark.loops import merged_record
from lfd_track.benchmark.runner import (
    repetition_preset,
    repetition_seeds,
    repetition_streams,
    run_loop_trials,
    run_trials,
)
from lfd_track.benchmark.tables import build_results, write_results_json
from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import run_demonstration
from lfd_track.envs.presets import Preset, load_preset
from lfd_track.policy.map_geometry import MapGeometry
from lfd_track.policy.memory_config import FreshFeltConfig
from lfd_track.study.spec import load_study
from lfd_track.study.stats import rate_summary
from lfd_track.teaching.handwritten import (
    FreshFeltRule,
    FreshFeltRuleConfig,
    RoadRule,
    RoadRuleConfig,
)
from lfd_track.teaching.perception import Perception
from lfd_track.teaching.scripted import HumanConfig
from lfd_track.vision.road_library import RoadLibrary

HERE = Path(__file__).resolve().parent
STUDY = HERE / "generalization.toml"
OUT = HERE / "results" / "rules"
RULES = {
    "road-rule": RoadRuleConfig(turn_at=1.5, latch=True),
    "map-rule": FreshFeltRuleConfig(
        turn_deg=HumanConfig().picture_turn_deg, memory=FreshFeltConfig()
    ),
}


@dataclasses.dataclass
class RuleController:
    """A hand-written rule driving as a controller does: a frozen library, its memory inputs
    (``geometry``: the map's camera and motion; None, the paper's constants)."""

    library: RoadLibrary
    rule: str
    geometry: MapGeometry | None = None

    def perception(self) -> Perception:
        config = RULES[self.rule]
        return Perception(self.library, "frozen", config.memory, geometry=self.geometry)

    def commander(self) -> Any:
        config = RULES[self.rule]
        return RoadRule(config) if isinstance(config, RoadRuleConfig) else FreshFeltRule(config)


def map_settings(pairs: list[str]) -> FreshFeltConfig:
    """The map-rule's map with ``KEY=VALUE`` settings changed (each parsed as its default's type)."""
    base = FreshFeltConfig()
    changes: dict[str, Any] = {}
    for pair in pairs:
        key, _, text = pair.partition("=")
        if not hasattr(base, key):
            raise SystemExit(f"--map {pair}: the fresh_felt map has no setting {key!r}")
        default = getattr(base, key)
        if isinstance(default, bool):
            changes[key] = text.lower() in ("1", "true", "yes")
        else:
            changes[key] = type(default)(text)
    return dataclasses.replace(base, **changes)


def library_of(demo_seed: int, preset: str | Preset) -> RoadLibrary:
    """The road library of the paper's demonstration with ``demo_seed``."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "demonstration.lfdemo"
        run_demonstration(path, seed=demo_seed, preset=preset, fsync=False)
        return RoadLibrary.from_dict(load_demonstration(path).metadata["road_library"])


def run_repetition(job: tuple[int, int, int, BenchmarkConfig]) -> dict[str, Any]:
    """Both rules on one repetition's trials."""
    seed, index, repetition_seed, config = job
    demo_seed, _, trial_seed = repetition_streams(repetition_seed)
    # With rooms kept per repetition, the repetition's own room (as the study's job draws it),
    # its map with that room's camera and motion; otherwise the preset and the paper's constants.
    preset = repetition_preset(config, repetition_seed)
    geometry = None
    if config.room == "per_repetition":
        world = load_preset(preset) if isinstance(preset, str) else preset
        geometry = MapGeometry.from_preset(world)
    library = library_of(demo_seed, preset)
    rows = {}
    for rule in RULES:
        controller = RuleController(library, rule, geometry)
        t0 = time.perf_counter()
        outcomes = run_trials(
            controller,
            trial_seed=trial_seed,
            test_tracks=config.test_tracks,
            trials_per_direction=config.trials_per_direction,
            preset=preset,
            repetition=index,
        )
        loops, record = run_loop_trials(
            controller, trial_seed=trial_seed, config=config, repetition=index, preset=preset
        )
        rows[rule] = {
            "outcomes": outcomes + loops,
            "record": record,
            "wall_s": time.perf_counter() - t0,
        }
    return {"seed": seed, "repetition": index, "rules": rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--study", type=Path, default=STUDY, help="study file whose trials to use")
    parser.add_argument("--condition", default="paper", help="its condition giving the trials")
    parser.add_argument("--repetitions", type=int, default=None, help="first N per seed")
    parser.add_argument("--out", type=Path, default=OUT, help="output folder")
    parser.add_argument(
        "--rule", action="append", choices=sorted(RULES), help="only these rules (default: both)"
    )
    parser.add_argument(
        "--map",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a setting of the map-rule's fresh_felt map other than the shipped default",
    )
    args = parser.parse_args()
    # The rules this run scores, set in the module before the workers fork from it.
    for name in set(RULES) - set(args.rule or RULES):
        del RULES[name]
    if "map-rule" in RULES and args.map:
        RULES["map-rule"] = dataclasses.replace(RULES["map-rule"], memory=map_settings(args.map))
    study = load_study(args.study)
    out: Path = args.out
    repetitions = args.repetitions or study.repetitions
    base = next(c for c in study.conditions if c.name == args.condition).config
    jobs = [
        (seed, index, repetition_seed, base)
        for seed in study.seeds
        for index, repetition_seed in enumerate(repetition_seeds(seed, repetitions))
    ]
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        done = list(pool.map(run_repetition, jobs))
    lines = [
        f"# The hand-written rules on the trials of {args.study.name} ({args.condition}),"
        f" seeds {', '.join(map(str, study.seeds))} x {repetitions} repetitions",
        "",
        "| rule | testing track | other named tracks | procedural test loops | <=60 | 60-100"
        " | 100-135 | >135 |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for rule in RULES:
        pooled_testing = [0, 0]
        pooled_named = [0, 0]
        pooled_loops = {"laps": 0, "successes": 0}
        bins: dict[str, list[int]] = {}
        for seed in study.seeds:
            mine = [d for d in done if d["seed"] == seed]
            outcomes = [o for d in mine for o in d["rules"][rule]["outcomes"]]
            record = merged_record((d["repetition"], d["rules"][rule]["record"]) for d in mine)
            results = build_results(
                outcomes,
                repetitions=repetitions,
                seed=seed,
                timing_s={"wall": sum(d["rules"][rule]["wall_s"] for d in mine)},
                random_loops=record,
                test_tracks=base.test_tracks,
            )
            results["rule"] = {"name": rule, "config": dataclasses.asdict(RULES[rule])}
            folder = out / rule / f"seed{seed}"
            folder.mkdir(parents=True, exist_ok=True)
            write_results_json(folder / "results.json", results)
            testing = [o for o in outcomes if o.track == "testing"]
            pooled_testing[0] += sum(o.success for o in testing)
            pooled_testing[1] += len(testing)
            named = [o for o in outcomes if o.track in base.test_tracks and o.track != "testing"]
            pooled_named[0] += sum(o.success for o in named)
            pooled_named[1] += len(named)
            section = results.get(
                "random_loops", {"laps": 0, "successes": 0, "by_sharpest_turn": {}}
            )
            pooled_loops["laps"] += section["laps"]
            pooled_loops["successes"] += section["successes"]
            for label, row in section["by_sharpest_turn"].items():
                acc = bins.setdefault(label, [0, 0])
                acc[0] += row["successes"]
                acc[1] += row["laps"]

        def cell(k: int, n: int) -> str:
            r = rate_summary(k, n)
            low, high = r["ci95"]
            return "–" if not n else f"{k}/{n} = {k / n:.0%} [{low:.0%}–{high:.0%}]"

        lines.append(
            f"| {rule} | {cell(*pooled_testing)} | {cell(*pooled_named)} "
            f"| {cell(pooled_loops['successes'], pooled_loops['laps'])} | "
            + " | ".join(cell(*bins.get(x, [0, 0])) for x in ("<=60", "60-100", "100-135", ">135"))
            + " |"
        )
    (out / "rules.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
