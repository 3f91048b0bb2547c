"""What one benchmark run does: :class:`BenchmarkConfig`, and its form in results.json
(:func:`config_dict`, read back by :meth:`BenchmarkConfig.from_dict`).

The learning method is a name from the registry (:mod:`lfd_track.methods`), whose entry says
which options the method takes and where its settings are.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ..core.config import config_from_dict
from ..demo.demonstrator import HumanConfig
from ..learning.bc import BCConfig
from ..learning.cmaes import CMAESConfig
from ..learning.ga import GAConfig
from ..learning.result import check_int
from ..methods import (
    DaggerConfig,
    HGDaggerConfig,
    Method,
    OnlineConfig,
    get_method,
    method_of_table,
    methods,
)
from ..policy.controller import POLICY_KINDS
from ..policy.features import DEFAULT_FEATURES, check_features
from ..policy.memory import MemoryConfig, NoMemory
from ..policy.mlp import N_HIDDEN
from ..world.loops import SPLITS

# Limits of the integer settings: generous (far beyond any run that finishes in days), but a typo
# such as a trillion repetitions or a 400-digit seed is refused at once instead of hanging.
MAX_REPETITIONS = 10_000
"""Most repetitions a benchmark may have (the paper's totals come from 10)."""
MAX_TRIALS_PER_DIRECTION = 1_000
"""Most autonomous runs per direction per repetition (the paper's: 3)."""
MAX_SEED = 2**32 - 1
"""Largest benchmark seed (seeds are 0..2**32-1, like the study files')."""
MAX_RANDOM_LOOPS = 10_000
"""Most procedural loops lapped per repetition."""
ROOMS = ("per_episode", "per_repetition")
"""Values of ``room``: when a preset with ``[randomization]`` draws its world."""


@dataclass(frozen=True)
class BenchmarkConfig:
    """What one benchmark run does.

    Limits (anything else is refused at construction in one line naming the setting):
    ``repetitions`` 1..10 000, ``trials_per_direction`` 1..1000, ``seed`` 0..2**32-1,
    ``random_loops`` 0..10 000 (``random_split`` one of ``train``, ``validation``, ``test``),
    ``room`` one of ``per_episode``, ``per_repetition``; the
    learners' settings have their own (``GAConfig``: population and tournament size
    1..100 000, generations 1..1 000 000; see each config class).

    ``method`` is the name of a registered method (:mod:`lfd_track.methods`); its entry says
    which options it takes (``shifted_views``, ``policy_kind``) and where its settings are: the
    built-in methods' in the fields ``online``, ``hg_dagger``, ``bc``, ``cmaes`` and ``dagger``,
    any other's in ``method_settings`` under its table name (:meth:`settings_of` reads either).
    """

    repetitions: int = 10  # fresh demonstration + evolution each (the paper's totals: 10)
    seed: int = 0  # benchmark seed; repetition seeds are spawned from it
    trials_per_direction: int = 3  # autonomous runs per direction per repetition
    preset: str = "paper"  # environment preset for demonstration and trials
    human: HumanConfig = HumanConfig()
    ga: GAConfig = GAConfig()
    keep_learning: bool = False  # let the road library keep learning during autonomous runs
    method: str = "paper"  # how the controller is learned: a registered method's name
    online: OnlineConfig = OnlineConfig()  # settings of method "online"
    hg_dagger: HGDaggerConfig = HGDaggerConfig()  # settings of method "hg-dagger"
    bc: BCConfig = BCConfig()  # settings of method "bc" (backprop on the same network)
    cmaes: CMAESConfig = CMAESConfig()  # settings of method "cma-es"
    # Settings of method "dagger" (its learner's own settings are ``ga`` or ``bc`` above).
    dagger: DaggerConfig = DaggerConfig()
    test_tracks: tuple[str, ...] = ("testing",)  # loops (names or paths) lapped both ways
    memory: MemoryConfig = NoMemory()  # memory inputs of the policy (none: the paper's 40)
    mirror: bool = False  # learn from the cases and their mirror images (learning/mirror.py)
    # Learn also from the shifted and turned views of every case (demo/views.py): the methods
    # registered with takes_views ("paper", "bc", "cma-es": one simulated demonstration, then
    # learning).
    shifted_views: bool = False
    # The network: "mlp-sigmoid" (the paper's) or "elman-sigmoid" (its hidden activations fed
    # back, policy/elman.py), for the methods whose entry lists it in policy_kinds: the GA
    # (method "paper") and backprop through time (method "bc") over the cases in order.
    policy_kind: str = "mlp-sigmoid"
    # Per-region inputs of the policy (policy/features.py): the paper's road values,
    # "road_values+colour" (also each region's mean hue and saturation), "near_felt" (where the
    # felt lies across the picture's two nearest rows, and how much: 2) or "none" (the memory
    # inputs alone).
    features: str = DEFAULT_FEATURES
    # The track the human demonstrates on (and HG-DAgger's rounds drive); the paper's
    # training track by default. Trials still run the paper's training track both ways.
    demo_track: str = "training"
    # Settings of methods registered beyond the built-in ones, by table name (an entry equal to
    # the method's defaults is dropped: a missing table means the defaults).
    method_settings: dict[str, Any] = field(default_factory=dict, hash=False)
    # Procedural loops (lfd_track/world/loops.py) lapped per repetition, once each way: each
    # repetition draws its own loops of ``random_split`` from its own stream, a loop entering the
    # score only once the default scripted human laps it both ways (benchmark/loops.py).
    random_loops: int = 0
    # The split they are drawn from: "train" and "validation" to choose settings on, "test" to
    # score a frozen configuration once.
    random_split: str = "validation"
    # When a preset with [randomization] draws its world: "per_episode" (a new room at every
    # episode, the preset as it is) or "per_repetition" (one room per repetition, drawn from its
    # own stream and kept for the demonstration, the learning and every trial: a user's own
    # room). A preset without randomization has one world either way. The robustness rooms
    # study (benchmarks/experiments/robustness/rooms.toml) uses it, and it
    # is how a user teaches and drives in one kept room.
    room: str = "per_episode"
    # Saved cases the offline learners (the methods registered with takes_views: "paper", "bc",
    # "cma-es") fit after the repetition's own: a .npz file or a folder of them, read in the order
    # of the files' names (learning/extra_cases.py; checked when a study file is loaded, when the
    # benchmark command starts and at the fit). The
    # human goal's round 41 (benchmarks/experiments/human_goal/round41/) adds ten other rooms'
    # demonstrations this way. Empty: the repetition's own cases alone.
    extra_cases: str = ""

    def __post_init__(self) -> None:
        if isinstance(self.test_tracks, str) or not all(
            isinstance(t, str) and t for t in self.test_tracks
        ):
            raise ValueError("test_tracks must be a list of track names or paths")
        if len(set(self.test_tracks)) != len(self.test_tracks):
            raise ValueError("test_tracks lists a track twice")
        object.__setattr__(self, "test_tracks", tuple(self.test_tracks))
        if not isinstance(self.demo_track, str) or not self.demo_track:
            raise ValueError("demo_track must be a track name or path")
        method = get_method(self.method)  # an unknown name is refused, naming the known ones
        self._check_method_settings(method)
        check_int("repetitions", self.repetitions, 1, MAX_REPETITIONS)
        check_int("trials_per_direction", self.trials_per_direction, 1, MAX_TRIALS_PER_DIRECTION)
        check_int("seed", self.seed, 0, MAX_SEED)
        check_int("random_loops", self.random_loops, 0, MAX_RANDOM_LOOPS)
        if self.random_split not in SPLITS:
            raise ValueError(
                f"random_split must be one of {', '.join(SPLITS)}, got {self.random_split!r}"
            )
        if self.room not in ROOMS:
            raise ValueError(f"room must be one of {', '.join(ROOMS)}, got {self.room!r}")
        check_features(self.features)
        if self.human.steers_by == "picture" and self.memory.kind != "fresh_felt":
            raise ValueError(
                "human steers_by 'picture' reads the fresh_felt map: set memory kind 'fresh_felt'"
            )
        if self.shifted_views and not method.takes_views:
            raise ValueError(_offline_only("shifted_views applies", self.method))
        if self.extra_cases:
            self._check_extra_cases(method)
        if self.policy_kind not in POLICY_KINDS:
            raise ValueError(
                f"unknown policy_kind '{self.policy_kind}' (choose from {', '.join(POLICY_KINDS)})"
            )
        if self.policy_kind not in method.policy_kinds:
            trainers = [m.name for m in methods() if self.policy_kind in m.policy_kinds]
            raise ValueError(
                f"policy_kind '{self.policy_kind}' is trained by the methods"
                f" {', '.join(trainers)}, not '{self.method}'"
            )
        if self.policy_kind == "elman-sigmoid" and self.bc.ensemble != 1:
            raise ValueError("an Elman network is one network: backprop's ensemble must be 1")
        if self.bc.hidden != N_HIDDEN and self.policy_kind == "elman-sigmoid":
            raise ValueError(f"an Elman network has {N_HIDDEN} hidden nodes: bc hidden must be 5")
        if self.bc.hidden != N_HIDDEN and self.method == "dagger":
            raise ValueError(
                "method 'dagger' takes its network's width from dagger hidden, not bc hidden"
            )
        if self.bc.watched_fits != 1 and (self.method != "bc" or self.policy_kind != "mlp-sigmoid"):
            raise ValueError(
                "bc watched_fits chooses among the 'bc' method's fits of an MLP by watching them"
                f" drive; not with method '{self.method}', policy_kind '{self.policy_kind}'"
            )
        if self.policy_kind == "elman-sigmoid" and self.shifted_views:
            raise ValueError(
                "shifted_views have no place in the driven sequence an Elman network learns"
            )
        if self.features == "none" and not self.memory.n_inputs:
            raise ValueError(
                "features 'none' leave the policy only its memory inputs: set a memory kind"
            )

    def _check_extra_cases(self, method: Method) -> None:
        """``extra_cases`` is a path, for a method that fits after one demonstration, and not for
        an Elman network (its cases are a driven sequence). The files themselves are read and
        checked where a configuration is about to run (a study file's load, the benchmark
        command, the fit), not here: a results file read elsewhere still gives its settings."""
        if not isinstance(self.extra_cases, str):
            raise ValueError("extra_cases must be the path of saved cases (a .npz or a folder)")
        if not method.takes_views:
            raise ValueError(_offline_only("extra_cases apply", self.method))
        if self.policy_kind == "elman-sigmoid":
            raise ValueError(
                "extra_cases have no place in the driven sequence an Elman network learns"
            )

    def _check_method_settings(self, method: Method) -> None:
        """``method_settings`` holds only other methods' settings, each of its method's class
        (defaults dropped); the chosen method's settings are of its class."""
        if not isinstance(self.method_settings, Mapping):
            raise ValueError("method_settings must map settings table names to settings")
        fields = _field_names()
        kept: dict[str, Any] = {}
        for table, value in sorted(self.method_settings.items()):
            owner = method_of_table(table)
            if owner is None or table in fields or owner.settings is None:
                raise ValueError(f"method_settings: '{table}' is no registered method's table")
            if not isinstance(value, owner.settings):
                raise ValueError(
                    f"method_settings '{table}' must be {owner.settings.__name__} (the settings"
                    f" of method '{owner.name}'), got {type(value).__name__}"
                )
            if value != owner.default_settings():
                kept[table] = value
        object.__setattr__(self, "method_settings", kept)
        settings = self.settings_of(method)
        if method.settings is not None and not isinstance(settings, method.settings):
            raise ValueError(
                f"method '{method.name}': its settings table '{method.table}' is a benchmark"
                f" setting of another kind ({type(settings).__name__})"
            )

    def settings_of(self, method: Method | str | None = None) -> Any:
        """The settings of ``method`` (default: this run's), or None if it has none."""
        if not isinstance(method, Method):
            method = get_method(self.method if method is None else method)
        if method.settings is None:
            return None
        if method.table in _field_names():
            return getattr(self, method.table)
        stored = self.method_settings.get(method.table)
        return method.default_settings() if stored is None else stored

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> BenchmarkConfig:
        """Inverse of :func:`config_dict`: the settings as results.json stores them. Missing
        keys and method tables take their defaults; an unknown key or a bad value raises
        ``ValueError``."""
        if not isinstance(data, Mapping):
            raise ValueError("benchmark settings must be an object")
        hints = typing.get_type_hints(cls)
        fields = _field_names() - {"method_settings"}
        values: dict[str, Any] = {}
        tables: dict[str, Any] = {}
        for key, value in data.items():
            method = method_of_table(key)
            if method is not None and method.settings is not None:
                tables[key] = method.settings.from_dict(value)
            elif key not in fields:
                raise ValueError(f"unknown benchmark setting '{key}'")
            elif dataclasses.is_dataclass(hints[key]):
                kind = hints[key]
                if callable(getattr(kind, "from_dict", None)):
                    values[key] = kind.from_dict(value)
                else:
                    values[key] = config_from_dict(kind, value, key)
            elif key == "test_tracks" and isinstance(value, list):
                values[key] = tuple(value)
            else:
                values[key] = value
        try:
            return cls(**values, **settings_arguments(tables))
        except TypeError as exc:
            raise ValueError(f"benchmark settings: {exc}") from None


@functools.cache
def _field_names() -> frozenset[str]:
    return frozenset(f.name for f in dataclasses.fields(BenchmarkConfig))


def settings_arguments(tables: Mapping[str, Any]) -> dict[str, Any]:
    """:class:`BenchmarkConfig` keyword arguments holding the method settings ``tables``
    (table name → settings): a built-in method's as its field, any other's in
    ``method_settings``."""
    fields = _field_names()
    arguments = {t: v for t, v in tables.items() if t in fields}
    others = {t: v for t, v in tables.items() if t not in fields}
    return {**arguments, "method_settings": others} if others else arguments


def _offline_only(what: str, method: str) -> str:
    """The refusal of a setting only the methods that learn after one simulated demonstration
    take (those registered with ``takes_views``), for ``method``."""
    offline = ", ".join(m.name for m in methods() if m.takes_views)
    return f"{what} to the methods {offline} (one simulated demonstration, then learning), not '{method}'"


def config_dict(config: BenchmarkConfig) -> dict[str, Any]:
    """JSON-friendly form of a benchmark config (stored in results.json), every setting written:
    each field (nested settings as tables), the memory by its ``to_dict``, and the settings
    table of every registered method that has settings (a built-in one's field, or another's
    under its table name). :meth:`BenchmarkConfig.from_dict` reads it back.

    ``room`` is written only when it is not ``"per_episode"``: a file without it means a new
    room per episode, as every run did before the setting existed (so their files still match
    the settings that produced them); ``extra_cases`` likewise only when it names saved cases,
    the human's ``nudge_prob`` only when it is not 0, and its ``nudge_side`` only when it is not
    ``"random"``."""
    data: dict[str, Any] = {}
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if f.name == "method_settings" or (f.name, value) in (
            ("room", "per_episode"),
            ("extra_cases", ""),
        ):
            continue
        if f.name == "memory":
            data[f.name] = config.memory.to_dict()
        elif dataclasses.is_dataclass(value) and not isinstance(value, type):
            data[f.name] = dataclasses.asdict(value)
            if f.name == "human" and not data[f.name]["nudge_prob"]:
                del data[f.name]["nudge_prob"]
            if f.name == "human" and data[f.name]["nudge_side"] == "random":
                del data[f.name]["nudge_side"]
        else:
            data[f.name] = copy.deepcopy(value)
    for method in methods():
        if method.settings is not None:
            data[method.table] = config.settings_of(method).to_dict()
    return data
