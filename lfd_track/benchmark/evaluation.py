"""Score any policy with the paper's corner-success protocol (§4.2.5, §5).

:func:`evaluate` runs the benchmark's autonomous trials (:func:`~.runner.run_trials`: the same
worlds, seeds and counting) on a policy that someone else wrote or trained: runs both ways on
the training track and laps both ways on the testing track starting at corner 4, counted corner
by corner as in the paper's Tables 2 and 3, with Wilson 95 % intervals on every success rate.
Finding and driving a policy is :mod:`.policy_driver`'s job, the rates table and report.md
:mod:`.evaluation_report`'s; their public names are importable from here too.

A policy is one of:

* a :class:`~lfd_track.policy.controller.Controller` (or the path of a controller file, ``.json``):
  driven exactly as ``lfd-track benchmark`` drives the controllers it learns, through its own road
  library, so the same seed gives the same outcomes as the benchmark's first repetition;
* an object with ``predict(obs)`` (Stable-Baselines3 style; a ``(action, state)`` tuple is read
  as its action, and ``deterministic=True`` is passed when ``predict`` takes it) or ``act(obs)``;
* a plain function ``policy(obs) -> action``.

An object's ``reset()``, if it has one, is called at the start of every run. ``obs`` is the
camera frame (``observation="frames"``: RGB uint8 (480, 640, 3), read-only) or its 40 road values
(``observation="road-values"``: float32 (40,) in [-1, 1], exactly what
:class:`~lfd_track.envs.wrappers.RoadValueObservation` gives), which needs the road library to
compute them with. The action is 0 (forward), 1 (left) or 2 (right), the values of
:class:`~lfd_track.core.commands.Command`: an integer, a numpy integer, or a numpy array holding
one integer. A policy that raises or answers anything else stops the evaluation with a
:class:`PolicyError` of one line naming the policy, the problem and where it happened.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import LfdTrackError
from ..learning.result import check_int
from ..policy.controller import Controller
from ..utils.provenance import environment
from ..vision.road_library import RoadLibrary
from .evaluation_report import ours_cell, rates_section, success_rates, write_evaluation_report
from .paper import DIRECTION_TITLES, TRACK_RESULT_KEYS, TRIAL_COUNT_KEYS
from .policy_driver import PolicyDriver, PolicyError, describe_policy, load_library, load_policy
from .runner import (
    MAX_SEED,
    MAX_TRIALS_PER_DIRECTION,
    BenchmarkConfig,
    check_tracks,
    repetition_seeds,
    repetition_streams,
    run_trials,
    trial_directions,
)
from .tables import TrialOutcome, build_results, results_json_text

__all__ = [
    "DEFAULT_TRACKS",
    "OBSERVATIONS",
    "Evaluation",
    "PolicyError",
    "evaluate",
    "load_library",
    "load_policy",
    "rates_section",
    "trial_seed",
    "write_evaluation_report",
]

OBSERVATIONS = ("frames", "road-values")
"""What a policy reads: the camera frame, or its 40 road values."""
DEFAULT_TRACKS = ("training", "testing")
"""The paper's two tracks, each driven both ways."""


def trial_seed(seed: int) -> int:
    """The trial stream of an evaluation with ``seed``: that of the benchmark's first repetition
    with the same seed, so a controller it learned is scored on the very same worlds."""
    return repetition_streams(repetition_seeds(seed, 1)[0])[2]


@dataclass(frozen=True)
class Evaluation:
    """What :func:`evaluate` measured."""

    policy: str
    """How the policy is named in messages and in the report."""
    observation: str
    """``"frames"`` or ``"road-values"`` (a controller reads frames through its library)."""
    outcomes: list[TrialOutcome]
    """Every run, in the order driven (trajectories included)."""
    results: dict[str, Any]
    """The contents of results.json: the benchmark's counting (``training_track``,
    ``testing_track``, ``test_tracks``, ``outcomes`` ...) plus ``evaluation`` (what was run) and
    ``rates`` (successes, trials, rate and Wilson 95 % interval per track and direction)."""
    timing_s: dict[str, float] = field(default_factory=dict)

    @property
    def successes(self) -> int:
        """Runs that succeeded (every corner negotiated, then the finish)."""
        return sum(o.success for o in self.outcomes)

    @property
    def trials(self) -> int:
        """Runs driven."""
        return len(self.outcomes)

    @property
    def success_rate(self) -> float:
        """Share of the runs that succeeded."""
        return self.successes / self.trials

    def tables(self) -> str:
        """Tables 2 and 3 and the success rates as markdown (``ours (paper)`` cells)."""
        from .tables import format_tables

        return format_tables(self.results, ours=ours_cell(self.results))

    def write(self, out: str | Path) -> Path:
        """Write results.json, report.md, trajectories.png and its numbers (trajectories.csv) into the folder ``out`` (created
        if missing; each file replaced atomically); returns the report's path."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        from ..viz.plot_data import trajectories_table, write_picture
        from .report import all_plotted_outcomes, trajectories_picture

        info = self.results["evaluation"]
        config = BenchmarkConfig(
            repetitions=1,
            seed=int(self.results["seed"]),
            trials_per_direction=int(info["laps"]),
            preset=str(info["preset"]),
        )
        title = (
            f"Paths of every run of {self.policy}: {info['laps']} per direction,"
            f" seed {self.results['seed']}"
        )
        write_picture(
            out / "trajectories.png",
            trajectories_picture(config, self.outcomes, title=title),
            trajectories_table(all_plotted_outcomes(self.outcomes)),
        )
        from .tables import write_results_json

        write_results_json(out / "results.json", self.results)
        return write_evaluation_report(out, self.results)


def _check_tracks_argument(tracks: Sequence[str]) -> tuple[str, ...]:
    if isinstance(tracks, str | bytes | os.PathLike) or not all(
        isinstance(t, str) and t for t in tracks
    ):
        raise ValueError("tracks must be a list of track names or paths")
    tracks = tuple(tracks)
    if not tracks:
        raise ValueError("tracks lists no track")
    if len(set(tracks)) != len(tracks):
        raise ValueError("tracks lists a track twice")
    return tracks


def evaluate(
    policy: Any,
    *,
    tracks: Sequence[str] = DEFAULT_TRACKS,
    laps: int = 3,
    seed: int = 0,
    observation: str = "frames",
    library: RoadLibrary | str | os.PathLike[str] | None = None,
    preset: str = "paper",
    name: str | None = None,
    out: str | Path | None = None,
    progress: Callable[[TrialOutcome], None] | None = None,
) -> Evaluation:
    """Score ``policy`` with the benchmark's corner-success protocol.

    Args:
        policy: a function of the observation returning an action, an object with
            ``predict(obs)`` or ``act(obs)``, a :class:`Controller`, or a string for
            :func:`load_policy` (a controller file, ``module:name`` or ``file.py:name``).
        tracks: the tracks driven, each both ways: ``"training"`` (the paper's open track,
            runs from one end to the other) and loops with corners (``"testing"``, other shipped
            loops or ``.toml`` paths; laps of the testing track start at corner 4).
        laps: runs per track and direction (1..1000; the paper's: 3 per repetition, 30 in all).
        seed: 0..2**32-1; the worlds are those of ``lfd-track benchmark --seed`` (its first
            repetition), so the same seed scores every policy on the same floors.
        observation: ``"frames"`` (camera frames) or ``"road-values"`` (their 40 road values,
            computed with ``library``).
        library: the road library for ``"road-values"``: a :class:`RoadLibrary`, a controller
            file or a demonstration (:func:`load_library`); frozen while driving.
        preset: environment preset name or TOML path.
        name: how the policy is named in messages and the report (default: its spec or
            ``module:qualname``).
        out: also write results.json, report.md and trajectories.png into this folder.
        progress: called with each run's outcome as it ends.

    Raises a one-line ``LfdTrackError`` (:class:`PolicyError` for the policy's own faults) or
    ``ValueError`` for bad arguments, before any run where it can.
    """
    if observation not in OBSERVATIONS:
        raise ValueError(f"observation must be one of {', '.join(OBSERVATIONS)}")
    check_int("laps", laps, 1, MAX_TRIALS_PER_DIRECTION)
    check_int("seed", seed, 0, MAX_SEED)
    tracks = _check_tracks_argument(tracks)
    if isinstance(policy, str | os.PathLike):
        name = name or os.fspath(policy)
        policy = load_policy(policy)
    name = name or describe_policy(policy)
    shown = f"'{name}'"
    # The benchmark's trial directions with these loops (the testing track always among them, as
    # `lfd-track benchmark --test-track` has it): every direction's world seed is drawn, those of
    # the tracks not driven too, so a direction's runs never depend on which others are driven.
    loops = ("testing", *(t for t in tracks if t not in ("training", "testing")))
    # Loops with corners, and every track buildable with the preset, before anything runs.
    check_tracks(BenchmarkConfig(trials_per_direction=laps, preset=preset, test_tracks=loops))
    library_name: str | None = None
    if isinstance(policy, Controller):
        if observation != "frames" or library is not None:
            raise LfdTrackError(
                f"policy {shown}: a controller reads frames through its own road library"
                " (leave out observation and library)"
            )
        driver: Any = policy
    else:
        road_library = None
        if observation == "road-values":
            if library is None:
                raise LfdTrackError(
                    f"policy {shown}: observation 'road-values' needs a road library (a"
                    " controller file or a demonstration, e.g. --library controller.json)"
                )
            road_library = load_library(library)
            if not isinstance(library, RoadLibrary):
                library_name = os.fspath(library)
        elif library is not None:
            raise LfdTrackError(
                f"policy {shown}: a road library is read only with observation 'road-values'"
            )
        driver = PolicyDriver(policy, shown, observation, road_library)

    planned = [
        (track, direction, trial)
        for track, _, direction in trial_directions(loops)
        if track in tracks
        for trial in range(laps)
    ]
    outcomes: list[TrialOutcome] = []

    def seen(outcome: TrialOutcome) -> None:
        outcomes.append(outcome)
        if isinstance(driver, PolicyDriver) and len(outcomes) < len(planned):
            _where(driver, planned[len(outcomes)])
        if progress is not None:
            progress(outcome)

    if isinstance(driver, PolicyDriver):
        _where(driver, planned[0])
    start = time.perf_counter()
    run_trials(
        driver,
        trial_seed=trial_seed(seed),
        test_tracks=loops,
        trials_per_direction=laps,
        preset=preset,
        tracks=tracks,
        progress=seen,
    )
    wall = time.perf_counter() - start
    timing = {"trials_sum": wall}
    raw = build_results(outcomes, repetitions=1, seed=seed, timing_s=timing)
    raw["evaluation"] = {
        "policy": name,
        "observation": observation,
        "laps": laps,
        "tracks": list(tracks),
        "preset": preset,
        "library": library_name,
    }
    raw["rates"] = success_rates(outcomes, tracks)
    raw["environment"] = environment()
    results = json.loads(results_json_text(raw))
    evaluation = Evaluation(name, observation, outcomes, results, timing)
    if out is not None:
        evaluation.write(out)
    return evaluation


def _where(driver: PolicyDriver, trial: tuple[str, str, int]) -> None:
    track, direction, index = trial
    title = DIRECTION_TITLES[direction].lower()
    kind = "run" if track in TRACK_RESULT_KEYS and TRIAL_COUNT_KEYS[track] == "trials" else "lap"
    driver.where = f"{kind} {index + 1} on the {track} track, {title}"
