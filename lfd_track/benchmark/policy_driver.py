"""A policy someone else wrote, as the benchmark's driver: found from its spec
(:func:`load_policy`), given road values through a road library (:func:`load_library`), and
driven through the benchmark's loop (:class:`PolicyDriver`), every answer checked to be an action.

What a policy may be is described in :mod:`lfd_track.benchmark.evaluation`.
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..core.commands import Command
from ..errors import FileFormatError, LfdTrackError, first_line
from ..policy.controller import Controller
from ..teaching.perception import Percept, Perception
from ..vision.road_library import RoadLibrary

__all__ = ["PolicyDriver", "PolicyError", "describe_policy", "load_library", "load_policy"]

_ACTIONS = "an action is 0 (forward), 1 (left) or 2 (right)"


class PolicyError(LfdTrackError):
    """The evaluated policy raised, or answered something that is not an action."""


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


def describe_policy(policy: Any) -> str:
    module = getattr(policy, "__module__", None)
    qualname = getattr(policy, "__qualname__", None)
    if module and qualname:
        return f"{module}:{qualname}"
    cls = type(policy)
    return f"{cls.__module__}:{cls.__qualname__} object"


class FramePerception:
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

    def __init__(self, driver: PolicyDriver) -> None:
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


class PolicyDriver:
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
            FramePerception() if library is None else Perception(library, "frozen")
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
