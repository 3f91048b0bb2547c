"""A trained controller: frozen road library + evolved MLP weights, saved as one JSON file.

``act(frame)`` runs the paper's autonomous loop for one frame: road values (Algorithm 2) → MLP →
the command with the largest output (an exact tie keeps the previous command).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .atomic import atomic_write_text
from .control.mlp import LAYER_SIZES, mlp_forward, n_weights, select_action
from .errors import FileFormatError
from .learning.ga import EvolutionResult, GAConfig
from .teaching.commanders import PolicyCommander
from .teaching.perception import Perception
from .vision.road_library import RoadLibrary

CONTROLLER_FORMAT = "lfd-track-controller"
CONTROLLER_SCHEMA_VERSION = 1
_KEYS = (
    "format",
    "schema_version",
    "layer_sizes",
    "bias",
    "weights",
    "road_library",
    "ga_config",
    "seed",
    "fitness_history",
    "learn",
)


class Controller:
    """Drives from camera frames with a road library and a 40-5-3 MLP.

    Args:
        library: the road library (frozen unless ``learn``).
        weights: (215,) MLP weights, or (223,) with ``bias=True``.
        bias: whether the weights include node biases.
        ga_config: GA settings the weights came from (stored for the record).
        seed: seed of the run that produced the weights (stored for the record).
        fitness_history: best fitness per generation (stored for the record).
        learn: also run Algorithm 1 on each frame before computing its road values.
    """

    def __init__(
        self,
        library: RoadLibrary,
        weights: np.ndarray,
        *,
        bias: bool = False,
        ga_config: GAConfig | None = None,
        seed: int | None = None,
        fitness_history: Sequence[float] | None = None,
        learn: bool = False,
    ) -> None:
        w = np.array(weights, dtype=np.float64, copy=True)
        if w.shape != (n_weights(bias),):
            raise ValueError(
                f"expected {n_weights(bias)} weights ({'with' if bias else 'without'} biases),"
                f" got shape {w.shape}"
            )
        if not np.all(np.isfinite(w)):
            raise ValueError("weights contain NaN or infinite values")
        w.flags.writeable = False
        self.library = library
        self.weights = w
        self.bias = bool(bias)
        self.ga_config = ga_config
        self.seed = seed
        self.fitness_history = (
            None if fitness_history is None else [float(f) for f in fitness_history]
        )
        self.learn = bool(learn)
        self._previous: int | None = None
        self.last_outputs: np.ndarray | None = None
        """MLP outputs (3,) of the latest ``act`` call."""

    @classmethod
    def from_evolution(
        cls, library: RoadLibrary, result: EvolutionResult, *, seed: int | None = None
    ) -> Controller:
        """Controller from an :func:`~lfd_track.learning.ga.evolve` result."""
        return cls(
            library,
            result.best_weights,
            bias=result.config.bias,
            ga_config=result.config,
            seed=seed,
            fitness_history=result.best_history.tolist(),
        )

    def reset(self) -> None:
        """Forget the previous command (start of an episode)."""
        self._previous = None
        self.last_outputs = None

    def act(self, frame: np.ndarray) -> int:
        """Command (0 forward, 1 left, 2 right) for an RGB uint8 (480, 640, 3) frame.

        The library learns from the frame first when ``learn`` is set (rule ``always``), else it
        is frozen (rule ``frozen``: not even selection counts change).
        """
        rule = "always" if self.learn else "frozen"
        return self.act_on_values(Perception(self.library, rule).perceive(frame).values)

    def commander(self) -> PolicyCommander:
        """This controller's network as a commander for the teaching loop."""
        return PolicyCommander(self.weights)

    def act_on_values(self, road_values: np.ndarray) -> int:
        """Command for precomputed road values, (40,) float."""
        outputs = mlp_forward(self.weights, np.asarray(road_values, dtype=np.float64)[None])[0]
        self.last_outputs = outputs
        self._previous = select_action(outputs, self._previous)
        return self._previous

    # ------------------------------------------------------------------------------- files
    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly contents of the controller file."""
        return {
            "format": CONTROLLER_FORMAT,
            "schema_version": CONTROLLER_SCHEMA_VERSION,
            "layer_sizes": list(LAYER_SIZES),
            "bias": self.bias,
            "weights": self.weights.tolist(),
            "road_library": self.library.to_dict(),
            "ga_config": None if self.ga_config is None else self.ga_config.to_dict(),
            "seed": self.seed,
            "fitness_history": self.fitness_history,
            "learn": self.learn,
        }

    def save(self, path: str | Path) -> None:
        """Write the controller file atomically (a reader never sees a partial file)."""
        text = json.dumps(self.to_dict(), allow_nan=False, separators=(",", ":"))
        atomic_write_text(path, text + "\n")

    @classmethod
    def load(cls, path: str | Path) -> Controller:
        """Read a controller file; anything malformed raises ``FileFormatError(path, problem)``."""
        try:
            text = Path(path).read_text(encoding="utf-8")
        except FileNotFoundError:
            raise FileFormatError(path, "file not found") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise FileFormatError(path, f"cannot read file ({exc.__class__.__name__})") from None
        try:
            data = json.loads(text, parse_constant=_reject_constant)
        except _NonFiniteError as exc:
            raise FileFormatError(path, f"non-finite number {exc} is not allowed") from None
        except json.JSONDecodeError as exc:
            raise FileFormatError(
                path, f"not valid JSON (truncated or corrupted?): {exc.msg} at line {exc.lineno}"
            ) from None
        except RecursionError:
            raise FileFormatError(path, "JSON nested too deeply to be a controller file") from None
        try:
            return cls._from_dict(data)
        except (ValueError, TypeError, OverflowError, RecursionError) as exc:
            raise FileFormatError(path, str(exc) or exc.__class__.__name__) from None

    @classmethod
    def _from_dict(cls, data: Any) -> Controller:
        if not isinstance(data, dict):
            raise ValueError("top level must be a JSON object")
        if data.get("format") != CONTROLLER_FORMAT:
            raise ValueError(f"not a controller file ('format' must be '{CONTROLLER_FORMAT}')")
        version = data.get("schema_version")
        if version != CONTROLLER_SCHEMA_VERSION:
            raise ValueError(
                f"schema version {version!r} is not supported"
                f" (this version of lfd-track reads {CONTROLLER_SCHEMA_VERSION})"
            )
        for key in _KEYS:
            if key not in data:
                raise ValueError(f"missing key '{key}'")
        unknown = sorted(set(data) - set(_KEYS))
        if unknown:
            raise ValueError(f"unknown key '{unknown[0]}'")
        if data["layer_sizes"] != list(LAYER_SIZES):
            raise ValueError(
                f"layer_sizes {data['layer_sizes']!r} not supported (expected {list(LAYER_SIZES)})"
            )
        bias = data["bias"]
        if not isinstance(bias, bool):
            raise ValueError("'bias' must be true or false")
        weights = data["weights"]
        if not isinstance(weights, list) or not all(_is_finite_number(w) for w in weights):
            raise ValueError("'weights' must be a list of finite numbers")
        if len(weights) != n_weights(bias):
            raise ValueError(
                f"expected {n_weights(bias)} weights for layers {list(LAYER_SIZES)}"
                f" {'with' if bias else 'without'} biases, got {len(weights)}"
            )
        library = RoadLibrary.from_dict(data["road_library"])
        ga_config = None if data["ga_config"] is None else GAConfig.from_dict(data["ga_config"])
        if ga_config is not None and ga_config.bias != bias:
            raise ValueError("'bias' disagrees with ga_config.bias")
        seed = data["seed"]
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
            raise ValueError("'seed' must be an integer or null")
        history = data["fitness_history"]
        if history is not None and (
            not isinstance(history, list) or not all(_is_finite_number(f) for f in history)
        ):
            raise ValueError("'fitness_history' must be a list of numbers or null")
        learn = data["learn"]
        if not isinstance(learn, bool):
            raise ValueError("'learn' must be true or false")
        return cls(
            library,
            np.asarray(weights, dtype=np.float64),
            bias=bias,
            ga_config=ga_config,
            seed=seed,
            fitness_history=history,
            learn=learn,
        )


class _NonFiniteError(ValueError):
    pass


def _reject_constant(name: str) -> float:
    # json accepts NaN/Infinity by default; a controller file never legitimately holds them.
    raise _NonFiniteError(name)


def _is_finite_number(value: Any) -> bool:
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:  # an integer too large for a float
        return False
