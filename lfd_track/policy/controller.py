"""A trained controller: frozen road library + learned MLP weights, saved as one JSON file.

``act(frame)`` runs the paper's autonomous loop for one frame: road values (Algorithm 2) → MLP →
the command with the largest output (an exact tie keeps the previous command).

The file (schema 8) is one JSON object with the keys ``format``, ``schema_version``,
``policy_kind`` (``"mlp-sigmoid"``: the 40-5-3 sigmoid network, or ``"elman-sigmoid"``),
``layer_sizes``, ``bias``, ``weights`` (one network's, or with an ensemble k lists of them:
:attr:`Controller.members`), ``road_library``, ``learner`` (what trained it: ``"ga"``,
``"bc"``, ``"cma-es"``, ... or null), ``learner_config`` (the learner's settings as a JSON object,
or null), ``seed``, ``fitness_history``, ``learn``, ``features`` (the per-region feature set's
name, :mod:`lfd_track.policy.features`), ``memory`` (every memory setting,
:meth:`~lfd_track.policy.memory_config.MemoryConfig.to_dict`, or null), ``frame_size`` (``[width,
height]`` in pixels of the camera frames its library and network learned on: ``[640, 480]`` for
the paper's camera, ``[320, 240]`` for the half-size one of ``[camera] scale = 0.5``),
``map_geometry`` (the camera and per-command motion its ``fresh_felt`` map was taught with,
:meth:`~lfd_track.policy.map_geometry.MapGeometry.to_dict`; null without that map) and
``checksum``: the
SHA-256 (hex) of the canonical JSON (sorted keys, no spaces, UTF-8) of every other key, so a
changed digit anywhere is refused (unless the number still parses to the very same value, which
changes nothing). ``layer_sizes`` is ``[f + m, h, 3]``: f per-region inputs (40 road values, 160
with colour, 2 with ``"near_felt"``, 0 with ``"none"``, which need a memory), m memory inputs, h hidden
nodes.

Older files are read through one migration per schema step
(:data:`~lfd_track.policy.controller_schema.MIGRATIONS`), each turning a
file of schema k into one of schema k + 1: schema 1 (the first release: ``ga_config`` instead of
``learner``/``learner_config``, no ``policy_kind`` or checksum) gains ``learner="ga"``; schema
2 (no memory) gains ``memory: null``; schema 3 (memory, road values) gains ``features:
"road_values"``; schema 4's memory table, which left out each ``fresh_felt`` option that was
off, becomes the full table with the same meaning
(:func:`~lfd_track.policy.memory_config.memory_table_from_v1`); schema 5 gains ``frame_size:
[640, 480]`` (the only frame size before); schema 6 gains ``map_geometry``: a ``fresh_felt`` map
then had the paper's constants (the paper preset's camera, 0.10 m, 22.9°), and its memory table
``geometry = "paper"``; schema 7 is schema 8 with one network (schema 8 lets ``weights`` hold an
ensemble's, so a build that cannot drive one names the schema instead of the weights). The checksum of a file of
schema 2 or later is checked before it is migrated.

Policy kind ``"elman-sigmoid"`` (:mod:`lfd_track.policy.elman`) is an Elman network: its 5
previous hidden activations are 5 more inputs after all the others, so its ``layer_sizes`` are
``[n + 5, 5, 3]`` and its weights the MLP layout of ``n + 5`` inputs.

An ensemble (``weights`` of shape (k, W), 2 <= k <= :data:`~lfd_track.policy.mlp.MAX_MEMBERS`:
k networks of the same layout, e.g. backprop's ``ensemble`` fits) drives by the mean of its
networks' outputs (:func:`~lfd_track.policy.mlp.ensemble_forward`); an Elman network is one.

A network with another hidden width than the paper's 5 (``hidden``, e.g. 40-20-3 fitted by
backprop) says so in ``layer_sizes`` (``[40, 20, 3]``); older files load and drive as they did.
An Elman network has the paper's 5 hidden nodes.

Driving a controller on frames of another size than ``frame_size`` works (the 8 x 5 grid and
the safe box cover the same floor at any size, so the inputs mean the same) but the road values
differ a little: its perception prints one line naming both sizes on the first such frame
(:class:`~lfd_track.teaching.perception.Perception`), once per process and pair of sizes.
Likewise, driving a controller with a ``fresh_felt`` map in a world whose map geometry differs
from ``map_geometry`` beyond :data:`~lfd_track.policy.map_geometry.TOLERANCES` (``perception(
world_geometry=...)``) prints one line naming both geometries and the difference, once per
process and pair; the map keeps the recorded geometry (the robot's belief about itself).

A policy does not import its trainer: the GA appears here only as a type for ``from_evolution``.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.frame import FRAME_HEIGHT, FRAME_WIDTH, grid_fits
from ..errors import FileFormatError
from ..teaching.commanders import PolicyCommander
from ..teaching.perception import Perception
from ..utils.atomic import atomic_write_text
from ..utils.files import parse_json_file_text, read_regular_text
from ..vision.road_library import RoadLibrary
from .controller_schema import (
    CONTROLLER_SCHEMA,
    MAX_ABS_WEIGHT,
    check_ga_config,
    checksum,
    file_networks,
    is_finite_number,
    migrate,
)
from .elman import N_CONTEXT, ElmanCommander, ElmanState
from .features import DEFAULT_FEATURES, FEATURE_SETS, check_features
from .map_geometry import PAPER_GEOMETRY, MapGeometry
from .memory import FreshFeltConfig, MemoryConfig, policy_inputs
from .mlp import (
    MAX_HIDDEN,
    MAX_MEMBERS,
    N_HIDDEN,
    check_hidden,
    check_numbers,
    ensemble_forward,
    layer_sizes,
    n_weights,
    select_action,
)

if TYPE_CHECKING:
    from ..learning.ga import EvolutionResult

CONTROLLER_FORMAT = "lfd-track-controller"
POLICY_KINDS = ("mlp-sigmoid", "elman-sigmoid")
"""Policy kinds this version of lfd-track can run."""
MAX_FILE_BYTES = 256 << 20
"""Largest controller file read (a 100-model library at 256 bins is a few MB)."""


class Controller:
    """Drives from camera frames with a road library and a 40-5-3 MLP.

    Args:
        library: the road library (frozen unless ``learn``); must hold at least one model.
        weights: (215,) MLP weights, or (223,) with ``bias=True``; finite, |w| <= 1e6; or (k, W)
            for an ensemble of k such networks (2..MAX_MEMBERS), driving by their mean outputs.
        bias: whether the weights include node biases.
        learner: what produced the weights ("ga", "bc", "cma-es", "online", "hg-dagger", ...),
            stored for the record.
        learner_config: the learner's settings (a JSON-friendly dict), stored for the record.
        seed: seed of the run that produced the weights (stored for the record).
        fitness_history: best fitness per generation (stored for the record).
        learn: also run Algorithm 1 on each frame before computing its road values.
        memory: the memory inputs the network reads after the per-region features (None: none).
        features: the per-region features the network reads
            (:data:`~lfd_track.policy.features.FEATURE_SETS`; default the 40 road values).
        policy_kind: ``"mlp-sigmoid"`` (the paper's network) or ``"elman-sigmoid"`` (its hidden
            activations fed back: 5 more weights per hidden node, :mod:`lfd_track.policy.elman`).
        hidden: nodes of the hidden layer (the paper's 5; 1..1000), recorded in ``layer_sizes``
            (an Elman network has 5).
        frame_size: (width, height) [px] of the camera frames the library and network learned
            on (the paper's 640 x 480 by default; a camera's ``frame_width_px``,
            ``frame_height_px``).
        map_geometry: the camera and per-command motion of the world its ``fresh_felt`` map was
            taught in (:mod:`lfd_track.policy.map_geometry`; None: the paper's constants).
            Recorded only with that map (else None); with ``geometry = "paper"`` it is the
            paper's constants whatever is passed.
    """

    policy_kind = "mlp-sigmoid"

    def __init__(
        self,
        library: RoadLibrary,
        weights: np.ndarray,
        *,
        bias: bool = False,
        learner: str | None = None,
        learner_config: Mapping[str, Any] | None = None,
        seed: int | None = None,
        fitness_history: Sequence[float] | None = None,
        learn: bool = False,
        memory: MemoryConfig | None = None,
        features: str = DEFAULT_FEATURES,
        policy_kind: str = "mlp-sigmoid",
        hidden: int = N_HIDDEN,
        frame_size: tuple[int, int] = (FRAME_WIDTH, FRAME_HEIGHT),
        map_geometry: MapGeometry | None = None,
    ) -> None:
        _check_library(library)
        frame_size = check_frame_size(frame_size)
        features = check_features(features)
        if policy_kind not in POLICY_KINDS:
            raise ValueError(
                f"policy kind {policy_kind!r} is not supported (this lfd-track runs"
                f" {', '.join(POLICY_KINDS)})"
            )
        hidden = check_hidden(hidden)
        if policy_kind == "elman-sigmoid" and hidden != N_HIDDEN:
            raise ValueError(f"an Elman network has {N_HIDDEN} hidden nodes, not {hidden}")
        context = N_CONTEXT if policy_kind == "elman-sigmoid" else 0
        if memory is not None and not isinstance(memory, MemoryConfig):
            raise TypeError(f"memory must be a MemoryConfig or None, got {type(memory).__name__}")
        memory = None if memory is None or memory.kind == "none" else memory
        if features == "none" and memory is None:
            raise ValueError(
                "features 'none' leave the network only its memory inputs: it needs a memory"
            )
        n_inputs = policy_inputs(memory, features) + context
        w = np.array(weights, dtype=np.float64, copy=True)
        if w.ndim == 2 and w.shape[0] == 1:
            w = w[0]  # an ensemble of one is its network
        if w.ndim == 2 and policy_kind == "elman-sigmoid":
            raise ValueError("an Elman network is one network, not an ensemble")
        if w.ndim == 2 and not 2 <= w.shape[0] <= MAX_MEMBERS:
            raise ValueError(f"an ensemble holds 2..{MAX_MEMBERS} networks, got {w.shape[0]}")
        if w.ndim not in (1, 2) or w.shape[-1] != n_weights(bias, n_inputs, hidden):
            raise ValueError(
                f"expected {n_weights(bias, n_inputs, hidden)} weights for {n_inputs} inputs"
                + ("" if hidden == N_HIDDEN else f" and {hidden} hidden nodes")
                + f" ({'with' if bias else 'without'} biases), got shape {w.shape}"
            )
        if not np.all(np.isfinite(w)):
            raise ValueError("weights contain NaN or infinite values")
        if np.abs(w).max() > MAX_ABS_WEIGHT:
            raise ValueError(f"a weight of {np.abs(w).max():.3g} is beyond +-{MAX_ABS_WEIGHT:g}")
        if learner is not None and (not isinstance(learner, str) or not learner.strip()):
            raise ValueError(f"learner must be a non-empty string or None, got {learner!r}")
        config = None if learner_config is None else dict(learner_config)
        if config is not None:
            try:
                json.dumps(config, allow_nan=False)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"learner_config is not JSON-friendly: {exc}") from None
        w.flags.writeable = False
        self.library = library
        self.weights = w
        self.bias = bool(bias)
        self.learner = learner
        self.learner_config = config
        self.seed = seed
        self.fitness_history = (
            None if fitness_history is None else [float(f) for f in fitness_history]
        )
        self.learn = bool(learn)
        self.memory = memory
        self.features = features
        self.policy_kind = policy_kind
        self.hidden = hidden
        self.frame_size = frame_size
        self.map_geometry = _map_geometry(memory, map_geometry)
        """The geometry its ``fresh_felt`` map assumes (None without that map)."""
        self._elman = (
            ElmanState(w, self.bias, n_inputs - context) if policy_kind == "elman-sigmoid" else None
        )
        self._act_perception: Perception | None = None
        self._previous: int | None = None
        self.last_outputs: np.ndarray | None = None
        """MLP outputs (3,) of the latest ``act`` call."""

    @classmethod
    def from_evolution(
        cls,
        library: RoadLibrary,
        result: EvolutionResult,
        *,
        seed: int | None = None,
        memory: MemoryConfig | None = None,
        features: str = DEFAULT_FEATURES,
        policy_kind: str = "mlp-sigmoid",
        frame_size: tuple[int, int] = (FRAME_WIDTH, FRAME_HEIGHT),
        map_geometry: MapGeometry | None = None,
    ) -> Controller:
        """Controller from an :func:`~lfd_track.learning.ga.evolve` result.

        ``library`` must be the road library the training cases' road values came from (a
        demonstration stores it: ``load_demonstration(path).road_library()``); an empty library
        is refused, since every road value it gives is 0 and the controller could not see the road.
        """
        _check_library(library)
        if library.n_models == 0:
            raise ValueError(
                "the road library is empty: pass the library the training cases were recorded"
                " with (e.g. load_demonstration(path).road_library())"
            )
        return cls(
            library,
            result.best_weights,
            bias=result.config.bias,
            learner="ga",
            learner_config=result.config.to_dict(),
            seed=seed,
            fitness_history=result.best_history.tolist(),
            memory=memory,
            features=features,
            policy_kind=policy_kind,
            frame_size=frame_size,
            map_geometry=map_geometry,
        )

    def relabelled(self, learner: str, learner_config: Mapping[str, Any] | None) -> Controller:
        """The same controller (every setting and weight kept), recording ``learner`` and its
        settings ``learner_config`` instead (a method that drives a learner, e.g. ``online``
        evolving with the GA, records itself)."""
        return type(self)(
            self.library,
            self.weights,
            bias=self.bias,
            learner=learner,
            learner_config=learner_config,
            seed=self.seed,
            fitness_history=self.fitness_history,
            learn=self.learn,
            memory=self.memory,
            features=self.features,
            policy_kind=self.policy_kind,
            hidden=self.hidden,
            frame_size=self.frame_size,
            map_geometry=self.map_geometry,
        )

    @property
    def members(self) -> int:
        """Networks of the policy: 1, or k for an ensemble driving by their mean outputs."""
        return 1 if self.weights.ndim == 1 else int(self.weights.shape[0])

    @property
    def _context(self) -> int:
        return N_CONTEXT if self.policy_kind == "elman-sigmoid" else 0

    @property
    def n_inputs(self) -> int:
        """Inputs of the network: the per-region features (40 road values, or 160 with colour)
        plus the memory inputs."""
        return policy_inputs(self.memory, self.features)

    def perception(
        self, rule: str | None = None, *, world_geometry: MapGeometry | None = None
    ) -> Perception:
        """A perception for driving with this controller: its library, ``rule`` (default:
        ``always`` if it learns, else ``frozen``), its features and its memory inputs, its map
        with the recorded :attr:`map_geometry`. ``world_geometry``: the map geometry of the world
        it drives in; one that differs beyond the tolerances is noted in one line (see the
        module docstring)."""
        if rule is None:
            rule = "always" if self.learn else "frozen"
        return Perception(
            self.library,
            rule,
            self.memory,
            self.features,
            expected_frame_size=self.frame_size,
            geometry=self.map_geometry,
            world_geometry=world_geometry,
        )

    def reset(self) -> None:
        """Forget the previous command and the memory (start of an episode)."""
        self._previous = None
        self.last_outputs = None
        if self._elman is not None:
            self._elman.reset()
        if self._act_perception is not None:
            self._act_perception.start_episode()

    def act(self, frame: np.ndarray) -> int:
        """Command (0 forward, 1 left, 2 right) for an RGB uint8 (480, 640, 3) frame.

        The library learns from the frame first when ``learn`` is set (rule ``always``), else it
        is frozen (rule ``frozen``: not even selection counts change). With memory inputs, the
        command returned is taken as executed (call :meth:`reset` at each episode's start).
        """
        if self._act_perception is None:
            self._act_perception = self.perception()
        self._act_perception.rule = "always" if self.learn else "frozen"
        command = self.act_on_values(self._act_perception.perceive(frame).inputs)
        self._act_perception.note(command)
        return command

    def commander(self) -> PolicyCommander | ElmanCommander:
        """This controller's network as a commander for the teaching loop."""
        if self.policy_kind == "elman-sigmoid":
            return ElmanCommander(self.weights, self.bias, self.n_inputs)
        return PolicyCommander(self.weights, hidden=self.hidden)

    def act_on_values(self, road_values: np.ndarray) -> int:
        """Command for precomputed road values, (40,) float (then the colour features and the
        memory inputs, if the network reads them; with the features ``"none"`` the memory inputs
        alone: :attr:`Percept.inputs`).

        Raises ``ValueError`` for another shape or NaN / infinite values (a NaN would otherwise
        silently become command 0).
        """
        values = np.asarray(road_values)
        if values.shape != (self.n_inputs,):
            if self.features == "none":
                what = "the memory inputs"
            elif self.features == "near_felt":
                what = "the two near_felt inputs"
                what += "" if self.memory is None else ", then the memory inputs"
            else:
                what = "the road values"
                what += "" if self.features == DEFAULT_FEATURES else ", then the colour features"
                what += "" if self.memory is None else ", then the memory inputs"
            raise ValueError(
                f"road_values must have shape ({self.n_inputs},) ({what}), got {values.shape}"
            )
        check_numbers("road_values", values)
        values = values.astype(np.float64)
        if not np.isfinite(values).all():
            raise ValueError("road_values contain NaN or infinite values")
        if self._elman is not None:  # an Elman network: its context runs with it
            self._previous = self._elman.step(values)
            self.last_outputs = self._elman.last_outputs
            return self._previous
        outputs = ensemble_forward(self.weights, values[None], hidden=self.hidden)[0]
        self.last_outputs = outputs
        self._previous = select_action(outputs, self._previous)
        return self._previous

    # ------------------------------------------------------------------------------- files
    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly contents of the controller file (schema :data:`CONTROLLER_SCHEMA`, every
        setting written; checksum included)."""
        contents: dict[str, Any] = {
            "format": CONTROLLER_FORMAT,
            "schema_version": CONTROLLER_SCHEMA,
            "policy_kind": self.policy_kind,
            "layer_sizes": list(layer_sizes(self.n_inputs + self._context, self.hidden)),
            "bias": self.bias,
            "weights": self.weights.tolist(),
            "road_library": self.library.to_dict(),
            "learner": self.learner,
            "learner_config": self.learner_config,
            "seed": self.seed,
            "fitness_history": self.fitness_history,
            "learn": self.learn,
            "features": self.features,
            "memory": None if self.memory is None else self.memory.to_dict(),
            "frame_size": list(self.frame_size),
            "map_geometry": None if self.map_geometry is None else self.map_geometry.to_dict(),
        }
        contents["checksum"] = checksum(contents)
        return contents

    def save(self, path: str | Path) -> None:
        """Write the controller file atomically (a reader never sees a partial file)."""
        text = json.dumps(self.to_dict(), allow_nan=False, separators=(",", ":"))
        atomic_write_text(path, text + "\n")

    @classmethod
    def load(cls, path: str | Path) -> Controller:
        """Read a controller file; anything malformed raises ``FileFormatError(path, problem)``."""
        text = read_regular_text(path, MAX_FILE_BYTES, "controller")
        data = parse_json_file_text(path, text, "controller")
        try:
            return cls._from_dict(data)
        except (ValueError, TypeError, OverflowError, RecursionError) as exc:
            message = (str(exc) or exc.__class__.__name__).splitlines()[0]
            raise FileFormatError(path, message) from None

    @classmethod
    def _from_dict(cls, data: Any) -> Controller:
        if not isinstance(data, dict):
            raise ValueError("top level must be a JSON object")
        if data.get("format") != CONTROLLER_FORMAT:
            raise ValueError(f"not a controller file ('format' must be '{CONTROLLER_FORMAT}')")
        data = migrate(data)
        kind = data["policy_kind"]
        if kind not in POLICY_KINDS:
            raise ValueError(
                f"policy kind {kind!r} is not supported (this lfd-track runs"
                f" {', '.join(POLICY_KINDS)})"
            )
        learner, learner_config = data["learner"], data["learner_config"]
        memory = None
        if data["memory"] is not None:
            memory = MemoryConfig.from_dict(data["memory"])
            if memory.kind == "none":
                raise ValueError("a controller without memory stores null as its memory")
        features = data["features"]
        if not isinstance(features, str) or features not in FEATURE_SETS:
            raise ValueError(
                f"features {features!r} are not supported (this lfd-track reads"
                f" {', '.join(FEATURE_SETS)})"
            )
        if features == "none" and memory is None:
            raise ValueError(
                "features 'none' leave the network only its memory inputs: it needs a memory"
            )
        context = N_CONTEXT if kind == "elman-sigmoid" else 0
        expected = list(layer_sizes(policy_inputs(memory, features) + context))
        sizes = data["layer_sizes"]
        hidden = N_HIDDEN
        if (
            context == 0
            and isinstance(sizes, list)
            and len(sizes) == 3
            and isinstance(sizes[1], int)
            and not isinstance(sizes[1], bool)
            and 1 <= sizes[1] <= MAX_HIDDEN
        ):
            hidden = sizes[1]  # a wider (or narrower) hidden layer is recorded here
            expected[1] = hidden
        if sizes != expected:
            raise ValueError(f"layer_sizes {sizes!r} not supported (expected {expected})")
        n_inputs = expected[0]
        bias = data["bias"]
        if not isinstance(bias, bool):
            raise ValueError("'bias' must be true or false")
        networks = file_networks(
            data["weights"],
            kind,
            n_weights(bias, n_inputs, hidden),
            f"layer_sizes {expected} {'with' if bias else 'without'} biases",
        )
        library = RoadLibrary.from_dict(data["road_library"])
        if library.n_models == 0:
            raise ValueError("the road library is empty (a controller cannot see the road)")
        if learner is not None and (not isinstance(learner, str) or not learner.strip()):
            raise ValueError("'learner' must be a non-empty string or null")
        if learner_config is not None and not isinstance(learner_config, dict):
            raise ValueError("'learner_config' must be a JSON object or null")
        if learner == "ga" and learner_config is not None:
            check_ga_config(learner_config, bias)
        seed = data["seed"]
        if seed is not None and (
            isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**64
        ):
            raise ValueError("'seed' must be an integer in 0..2**64-1 or null")
        history = data["fitness_history"]
        if history is not None and (
            not isinstance(history, list)
            or not all(is_finite_number(f) and f >= 0 for f in history)
        ):
            raise ValueError("'fitness_history' must be a list of non-negative numbers or null")
        learn = data["learn"]
        if not isinstance(learn, bool):
            raise ValueError("'learn' must be true or false")
        size = data["frame_size"]
        if not (isinstance(size, list) and len(size) == 2):
            raise ValueError("'frame_size' must be [width, height] in pixels")
        frame_size = check_frame_size((size[0], size[1]))
        stored = data["map_geometry"]
        geometry = None if stored is None else MapGeometry.from_dict(stored)
        if (geometry is None) != (_map_geometry(memory, PAPER_GEOMETRY) is None):
            raise ValueError(
                "'map_geometry' must be recorded for a fresh_felt map, and null without one"
            )
        return cls(
            library,
            np.asarray(networks[0] if len(networks) == 1 else networks, dtype=np.float64),
            bias=bias,
            learner=learner,
            learner_config=learner_config,
            seed=seed,
            fitness_history=history,
            learn=learn,
            memory=memory,
            features=features,
            policy_kind=kind,
            hidden=hidden,
            frame_size=frame_size,
            map_geometry=geometry,
        )


def _map_geometry(memory: MemoryConfig | None, given: MapGeometry | None) -> MapGeometry | None:
    """The geometry a controller with ``memory`` records: None without a ``fresh_felt`` map, the
    paper's constants for one with ``geometry = "paper"`` (or when none is ``given``), else
    ``given``."""
    if not isinstance(memory, FreshFeltConfig):
        return None
    if given is None or memory.geometry == "paper":
        return PAPER_GEOMETRY
    if not isinstance(given, MapGeometry):
        raise TypeError(f"map_geometry must be a MapGeometry or None, got {type(given).__name__}")
    return given


def check_frame_size(size: Any) -> tuple[int, int]:
    """``size`` as (width, height) [px], or ``ValueError`` unless both are integers and the 8 x 5
    region grid divides the frame."""
    if (
        not isinstance(size, tuple)
        or len(size) != 2
        or not all(isinstance(v, int | np.integer) and not isinstance(v, bool) for v in size)
        or not grid_fits(int(size[0]), int(size[1]))
    ):
        raise ValueError(
            f"frame_size must be (width, height) in pixels that the 8 x 5 grid divides,"
            f" got {size!r}"
        )
    return int(size[0]), int(size[1])


def _check_library(library: Any) -> None:
    if not isinstance(library, RoadLibrary):
        raise TypeError(
            f"library must be a RoadLibrary, got {type(library).__name__} (a saved road library"
            " loads with RoadLibrary.from_dict, a saved controller with Controller.load(path))"
        )
