"""Score any policy with the paper's corner-success protocol (§4.2.5, §5).

:func:`evaluate` runs the benchmark's autonomous trials (:func:`~.runner.run_trials`: the same
worlds, seeds and counting) on a policy that someone else wrote or trained: runs both ways on
the training track and laps both ways on the testing track starting at corner 4, counted corner
by corner as in the paper's Tables 2 and 3, with Wilson 95 % intervals on every success rate.

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

import importlib
import importlib.util
import inspect
import json
import os
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core.commands import Command
from ..errors import FileFormatError, LfdTrackError, first_line
from ..learning.result import check_int
from ..policy.controller import Controller
from ..study.stats import rate_summary
from ..teaching.perception import Percept, Perception
from ..utils.provenance import environment
from ..vision.road_library import RoadLibrary
from .paper import DIRECTION_TITLES, TRACK_RESULT_KEYS, TRIAL_COUNT_KEYS
from .paper import DIRECTIONS as TABLE_DIRECTIONS
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
from .tables import LOOP_DIRECTIONS, TrialOutcome, build_results, results_json_text

__all__ = [
    "DEFAULT_TRACKS",
    "OBSERVATIONS",
    "Evaluation",
    "PolicyError",
    "evaluate",
    "load_library",
    "load_policy",
    "trial_seed",
]

OBSERVATIONS = ("frames", "road-values")
"""What a policy reads: the camera frame, or its 40 road values."""
DEFAULT_TRACKS = ("training", "testing")
"""The paper's two tracks, each driven both ways."""
_ACTIONS = "an action is 0 (forward), 1 (left) or 2 (right)"


class PolicyError(LfdTrackError):
    """The evaluated policy raised, or answered something that is not an action."""


def trial_seed(seed: int) -> int:
    """The trial stream of an evaluation with ``seed``: that of the benchmark's first repetition
    with the same seed, so a controller it learned is scored on the very same worlds."""
    return repetition_streams(repetition_seeds(seed, 1)[0])[2]


# --------------------------------------------------------------------------- loading


def _policy_from_file(path: Path, spec: str) -> Any:
    name = f"_lfd_track_policy_{abs(hash(str(path.resolve())))}"
    loader = importlib.util.spec_from_file_location(name, path)
    if loader is None or loader.loader is None:
        raise LfdTrackError(f"policy '{spec}': cannot load {path} as a Python module")
    module = importlib.util.module_from_spec(loader)
    sys.modules[name] = module
    loader.loader.exec_module(module)
    return module


def load_policy(spec: str | os.PathLike[str]) -> Any:
    """The policy ``spec`` names: a controller file (``.json``), ``module:attribute`` (a module
    on the path or in the current folder) or ``file.py:attribute``; the attribute may be
    dotted (``agents:zoo.careful``). Raises a one-line ``LfdTrackError`` when it cannot."""
    text = os.fspath(spec)
    if text.endswith(".json") or (":" not in text and Path(text).is_file()):
        return Controller.load(text)
    module_name, sep, attribute = text.rpartition(":")
    if not sep or not module_name or not attribute:
        raise LfdTrackError(
            f"policy '{text}': name a controller file (.json) or a callable as module:name"
        )
    try:
        if module_name.endswith(".py"):
            if not Path(module_name).is_file():
                raise LfdTrackError(f"policy '{text}': no file {module_name}")
            target: Any = _policy_from_file(Path(module_name), text)
        else:
            # Like `python -m`, the current folder is searched first for the module.
            added = os.getcwd() not in sys.path
            if added:
                sys.path.insert(0, os.getcwd())
            try:
                target = importlib.import_module(module_name)
            finally:
                if added:
                    sys.path.remove(os.getcwd())
    except LfdTrackError:
        raise
    except Exception as exc:
        raise LfdTrackError(
            f"policy '{text}': importing {module_name} failed: {type(exc).__name__}:"
            f" {first_line(exc)}"
        ) from None
    for part in attribute.split("."):
        if not hasattr(target, part):
            raise LfdTrackError(f"policy '{text}': {module_name} has no attribute '{attribute}'")
        target = getattr(target, part)
    return target


def load_library(source: RoadLibrary | str | os.PathLike[str]) -> RoadLibrary:
    """The road library to compute road values with: a :class:`RoadLibrary`, or the one stored in
    a controller file (``.json``) or a demonstration (``.lfdemo``). An empty one is refused."""
    if isinstance(source, RoadLibrary):
        library = source
        where = "library"
    else:
        path = Path(os.fspath(source))
        where = str(path)
        if path.suffix == ".json":
            library = Controller.load(path).library
        elif path.suffix == ".lfdemo":
            from ..dataset import load_demonstration

            try:
                library = load_demonstration(path).road_library()
            except FileFormatError:
                raise
            except ValueError as exc:
                raise FileFormatError(path, first_line(exc)) from None
        else:
            raise LfdTrackError(
                f"{where}: a road library comes from a controller file (.json) or a"
                " demonstration (.lfdemo)"
            )
    if library.n_models == 0:
        raise LfdTrackError(f"{where}: the road library is empty (every road value would be 0)")
    return library


def _describe(policy: Any) -> str:
    module = getattr(policy, "__module__", None)
    qualname = getattr(policy, "__qualname__", None)
    if module and qualname:
        return f"{module}:{qualname}"
    cls = type(policy)
    return f"{cls.__module__}:{cls.__qualname__} object"


# --------------------------------------------------------------------------- driving


class _FramePerception:
    """The loop's perception for a policy that reads frames: no road library, nothing computed."""

    _EMPTY = np.zeros(0)

    def start_episode(self) -> None:
        pass

    def note(self, command: Command | int) -> None:
        pass

    def perceive(self, frame: np.ndarray, box_on_felt: bool | None = None) -> Percept:
        return Percept(self._EMPTY, np.zeros(0, dtype=np.float32), False, box_on_felt)


def _action(value: Any) -> Command | None:
    """The command ``value`` stands for, or None when it is not an action."""
    if isinstance(value, bool | np.bool_):
        return None
    if isinstance(value, np.ndarray):
        if value.size != 1 or not np.issubdtype(value.dtype, np.integer):
            return None
        value = value.reshape(()).item()
    if isinstance(value, int | np.integer) and 0 <= int(value) <= 2:
        return Command(int(value))
    return None


def _shown(value: Any) -> str:
    if isinstance(value, np.ndarray):
        text = f"an array of shape {value.shape} and dtype {value.dtype}"
        if value.size == 1:
            text += f" ({value.reshape(()).item()!r})"
        return text
    if isinstance(value, np.generic):
        return f"{value.item()!r} ({value.dtype})"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


class _PolicyCommander:
    """The evaluated policy as the loop's commander."""

    def __init__(self, driver: _PolicyDriver) -> None:
        self.driver = driver

    def reset(self) -> None:
        self.driver.steps = 0
        reset = self.driver.reset_call
        if reset is not None:
            try:
                reset()
            except Exception as exc:
                problem = f"reset() raised {type(exc).__name__}: {first_line(exc)}"
                raise self.driver.error(problem) from None

    def propose(self, moment: Any) -> Command:
        driver = self.driver
        if driver.observation == "frames":
            obs = moment.frame.view()
            obs.flags.writeable = False
        else:
            obs = np.clip(moment.values, -1.0, 1.0).astype(np.float32)
        try:
            answer = driver.call(obs)
        except Exception as exc:
            raise driver.error(f"raised {type(exc).__name__}: {first_line(exc)}") from None
        if driver.unpack and isinstance(answer, tuple) and len(answer) == 2:
            answer = answer[0]  # SB3's predict: (action, state)
        command = _action(answer)
        if command is None:
            raise driver.error(f"returned {_shown(answer)}; {_ACTIONS}")
        driver.steps += 1
        return command


class _PolicyDriver:
    """What :func:`~.runner.run_trial` drives with: a perception and a commander."""

    def __init__(
        self, policy: Any, name: str, observation: str, library: RoadLibrary | None
    ) -> None:
        self.name = name
        self.observation = observation
        self.steps = 0
        self.where = ""
        self.unpack = False
        if isinstance(policy, type):
            raise PolicyError(f"policy {name}: is a class; name an instance of it (or a function)")
        if callable(getattr(policy, "predict", None)):
            self.call = self._predict_call(policy.predict)
            self.unpack = True
        elif callable(getattr(policy, "act", None)):
            self.call = policy.act
        elif callable(policy):
            self.call = policy
        else:
            raise PolicyError(
                f"policy {name}: is not a function and has no predict(obs) or act(obs) method"
            )
        reset = None if inspect.isroutine(policy) else getattr(policy, "reset", None)
        self.reset_call: Callable[[], Any] | None = reset if callable(reset) else None
        self._perception: Any = (
            _FramePerception() if library is None else Perception(library, "frozen")
        )

    @staticmethod
    def _predict_call(predict: Callable[..., Any]) -> Callable[[Any], Any]:
        try:
            parameters = inspect.signature(predict).parameters
        except (TypeError, ValueError):
            return predict
        takes = "deterministic" in parameters or any(
            p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values()
        )
        return (lambda obs: predict(obs, deterministic=True)) if takes else predict

    def error(self, problem: str) -> PolicyError:
        return PolicyError(f"policy {self.name}: {problem} (step {self.steps + 1} of {self.where})")

    def perception(self) -> Any:
        return self._perception

    def commander(self) -> _PolicyCommander:
        return _PolicyCommander(self)


# --------------------------------------------------------------------------- results


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

        return format_tables(self.results, ours=_ours(self.results))

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


def _ours(results: Mapping[str, Any]) -> str:
    info = results.get("evaluation", {})
    laps = info.get("laps", "?")
    return (
        f"policy `{info.get('policy', '?')}` on {info.get('observation', '?')},"
        f" {laps} per direction, seed {results.get('seed', '?')}"
    )


def _rates(outcomes: Sequence[TrialOutcome], tracks: Sequence[str]) -> dict[str, Any]:
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
        ours=_ours(results),
    )


# --------------------------------------------------------------------------- evaluate


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
    name = name or _describe(policy)
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
        driver = _PolicyDriver(policy, shown, observation, road_library)

    planned = [
        (track, direction, trial)
        for track, _, direction in trial_directions(loops)
        if track in tracks
        for trial in range(laps)
    ]
    outcomes: list[TrialOutcome] = []

    def seen(outcome: TrialOutcome) -> None:
        outcomes.append(outcome)
        if isinstance(driver, _PolicyDriver) and len(outcomes) < len(planned):
            _where(driver, planned[len(outcomes)])
        if progress is not None:
            progress(outcome)

    if isinstance(driver, _PolicyDriver):
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
    raw["rates"] = _rates(outcomes, tracks)
    raw["environment"] = environment()
    results = json.loads(results_json_text(raw))
    evaluation = Evaluation(name, observation, outcomes, results, timing)
    if out is not None:
        evaluation.write(out)
    return evaluation


def _where(driver: _PolicyDriver, trial: tuple[str, str, int]) -> None:
    track, direction, index = trial
    title = DIRECTION_TITLES[direction].lower()
    kind = "run" if track in TRACK_RESULT_KEYS and TRIAL_COUNT_KEYS[track] == "trials" else "lap"
    driver.where = f"{kind} {index + 1} on the {track} track, {title}"
