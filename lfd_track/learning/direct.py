"""Evolution without a human: the 40-5-3 network evolved on progress along the track, counted in
robot time (simulated seconds driven).

Two arrangements, both driving from the road values of a frozen road library (no human):

* :func:`direct_evolution` — the paper's GA (:mod:`lfd_track.learning.ga`, its ask/tell
  interface and Table 1 operators) with fitness = progress along the centreline instead of
  Algorithm 3. Offline in simulation: every evaluation starts from the track's start, once in
  each direction, and lasts at most the env's own step budget (3x an ideal driver, the budget a
  lap is scored in); it ends early when the rover leaves the felt or reverses (the env's
  episode rules) or *stalls* (its best progress grew less than ``stall_m`` in the last
  ``stall_steps`` commands: a network that spins in place stops costing robot time).
* :func:`mu_plus_one_online` — (μ+1)-ONLINE (Haasdijk, Eiben & Karafotias 2010), encapsulated:
  one robot carries μ genomes and evaluates one candidate at a time where it stands
  (:class:`OnboardRobot`), never reset to the start. Each evaluation is a free ``recovery``
  period (driven by the candidate, not scored) and ``tau`` scored commands; fitness is the
  progress along the centreline in the way the rover faces, minus ``put_back_penalty_m`` per
  time it left the felt. With probability ``reevaluation`` a random population member is
  evaluated again and its fitness becomes the mean of the old and the new value; otherwise a
  child (two binary tournaments, uniform crossover, Gaussian mutation of every weight with step
  ``sigma``) replaces the worst member if it is better. ``sigma`` is reset to ``sigma_min`` when
  a child gets in and doubled (up to ``sigma_max``) when it does not (:func:`adapt_sigma`).

When the rover leaves the felt in (μ+1)-ONLINE (both treads off), it is *put back by hand*
(counted in :attr:`OnlineResult.put_backs`): on the centreline where it left, facing along the
track the way it was facing, or, within ``end_margin_m`` of an end of an open track, facing back
into it (the turn-round a person makes at the end).

Robot time is every executed command times the env's control period, as ``learning_drive_s`` is
counted for the learning-from-demonstration methods (:mod:`lfd_track.methods`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.config import DictConfig
from ..envs.presets import Preset
from ..envs.track_env import LfDTrackEnv
from ..policy.mlp import n_weights
from ..teaching.commanders import PolicyCommander
from ..teaching.perception import Perception
from ..vision.road_library import RoadLibrary
from ..world.rover import Rover
from ..world.track import ProgressTracker
from .ga import GAConfig, ga_ask, ga_init, ga_tell, tournament_select, uniform_crossover
from .result import check_int, check_positive


class RoadDriver:
    """A network driving from the road values of a frozen library (no learning, no counts)."""

    def __init__(self, library: RoadLibrary) -> None:
        self.perception = Perception(library, "frozen")
        self.policy = PolicyCommander(None)

    def use(self, weights: np.ndarray) -> None:
        """Drive with ``weights`` from now on (the previous-command memory starts afresh)."""
        self.policy.weights = np.asarray(weights, dtype=np.float64)
        self.policy.reset()

    def command(self, frame: np.ndarray) -> int:
        values = self.perception.perceive(frame).values
        command = self.policy.act_on_values(values)
        assert command is not None, "use(weights) comes before the first command"
        return int(command)


# ------------------------------------------------------------------------------------ direct
@dataclass(frozen=True)
class DirectConfig(DictConfig):
    """Direct evolution settings (the GA's operators are the paper's Table 1).

    The defaults are the arrangement of the committed experiment
    (``benchmarks/experiments/limits``, part 5): population 10, up to 25 generations, stopped
    after the generation in which 4 000 s of robot time were spent.
    """

    settings_name = "direct"

    population_size: int = 10
    """Individuals per generation (2..100 000)."""
    generations: int = 25
    """Generations at most (1..1 000 000)."""
    robot_budget_s: float | None = 4_000.0
    """Stop after the generation in which this much robot time was spent (None: no limit)."""
    stall_steps: int = 25
    """A drive ends when its best progress grew less than ``stall_m`` in this many commands
    (1..1 000 000)."""
    stall_m: float = 0.05

    def __post_init__(self) -> None:
        check_int("direct population_size", self.population_size, 2, 100_000)
        check_int("direct generations", self.generations, 1, 1_000_000)
        check_int("direct stall_steps", self.stall_steps, 1, 1_000_000)
        check_positive("direct stall_m", self.stall_m)
        if self.robot_budget_s is not None:
            check_positive("direct robot_budget_s", self.robot_budget_s)


@dataclass
class DirectResult:
    best_weights: np.ndarray
    best_fitness: float
    """Progress [m] (both starts summed) of the best individual ever evaluated."""
    curve: list[dict[str, float]]
    """Per generation: robot_s (cumulative), best, mean, best_ever (progress, m)."""
    robot_s: float
    steps: int
    evaluations: int
    generations: int
    world_seeds: list[int]


def drive_from_start(
    env: LfDTrackEnv, driver: RoadDriver, weights: np.ndarray, stall_steps: int, stall_m: float
) -> tuple[float, int]:
    """One evaluation from the track's start (world kept): (progress [m], commands driven).

    Ends on the env's episode end (success, off the felt, reversed, its step budget) or when the
    best progress grew less than ``stall_m`` in the last ``stall_steps`` commands.
    """
    frame, info = env.reset()
    driver.use(weights)
    start = best = float(info["progress_m"])
    last_gain = steps = 0
    while True:
        frame, _, terminated, truncated, info = env.step(driver.command(frame))
        steps += 1
        progress = float(info["progress_m"])
        if progress >= best + stall_m:
            best, last_gain = progress, steps
        if terminated or truncated or steps - last_gain >= stall_steps:
            return progress - start, steps


def direct_evolution(
    library: RoadLibrary,
    config: DirectConfig,
    seed: int,
    *,
    track: str = "training",
    preset: str | Preset = "paper",
    progress: Callable[[dict[str, float]], None] | None = None,
) -> DirectResult:
    """The paper's GA on progress from the start of ``track``, both directions, one world per
    direction.

    The two worlds (floor, lighting) are drawn once from ``seed``; later evaluations redraw the
    rover, exposure and noise. Fitness to the GA is minus the summed progress.
    """
    ga_seq, world_seq = np.random.SeedSequence(seed).spawn(2)
    rng = np.random.default_rng(ga_seq)
    world_seeds = [int(s) for s in np.random.default_rng(world_seq).integers(0, 2**31, size=2)]
    envs = []
    for reverse, world_seed in zip((False, True), world_seeds, strict=True):
        env = LfDTrackEnv(track=track, reverse=reverse, preset=preset)
        env.reset(seed=world_seed)
        envs.append(env)
    period = float(envs[0].preset.rover.control_period_s)
    ga = GAConfig(population_size=config.population_size, generations=config.generations)
    state = ga_init(ga, rng)
    driver = RoadDriver(library)
    curve: list[dict[str, float]] = []
    steps = evaluations = 0
    for _ in range(config.generations):
        children = ga_ask(state, ga, rng)
        gains = np.zeros(len(children))
        for i, weights in enumerate(children):
            for env in envs:
                gain, n = drive_from_start(env, driver, weights, config.stall_steps, config.stall_m)
                gains[i] += gain
                steps += n
                evaluations += 1
        state = ga_tell(state, children, -gains)
        point = {
            "generation": state.generation,
            "robot_s": round(steps * period, 6),
            "best": float(gains.max()),
            "mean": float(gains.mean()),
            "best_ever": -state.best_fitness,
        }
        curve.append(point)
        if progress is not None:
            progress(point)
        if config.robot_budget_s is not None and steps * period >= config.robot_budget_s:
            break
    for env in envs:
        env.close()
    return DirectResult(
        best_weights=np.array(state.best_weights),
        best_fitness=-state.best_fitness,
        curve=curve,
        robot_s=round(steps * period, 6),
        steps=steps,
        evaluations=evaluations,
        generations=state.generation,
        world_seeds=world_seeds,
    )


# ------------------------------------------------------------------------------------ (μ+1)
@dataclass(frozen=True)
class MuPlusOneConfig(DictConfig):
    """Settings of (μ+1)-ONLINE, :func:`mu_plus_one_online` (evolution on one robot without a
    human; the ``online`` learning-from-demonstration method has its own settings,
    :class:`lfd_track.methods.online.OnlineConfig`).

    The defaults are the arrangement of the committed experiment
    (``benchmarks/experiments/limits``, part 5): μ = 10, τ = 50, 10 free commands, stopped after
    the evaluation in which 4 000 s of robot time were spent (167 evaluations).
    """

    settings_name = "mu-plus-one"

    mu: int = 10
    """Genomes on board (2..100 000)."""
    tau: int = 50
    """Scored commands per evaluation (1..1 000 000)."""
    recovery: int = 10
    """Free commands before each evaluation (driven by the candidate, not scored; 0..1 000 000)."""
    reevaluation: float = 0.2
    """Probability that a cycle re-evaluates a population member instead of breeding."""
    sigma_min: float = 0.1
    """Initial mutation step, and the step after a successful child."""
    sigma_max: float = 1.6
    init_range: float = 1.0
    """Initial weights uniform in [-init_range, init_range] (as the paper's GA)."""
    evaluations: int = 500
    """Evaluations at most, the μ initial ones included (1..10 000 000)."""
    robot_budget_s: float | None = 4_000.0
    """Stop after the evaluation in which this much robot time was spent (None: no limit)."""
    put_back_penalty_m: float = 1.0
    end_margin_m: float = 0.4

    def __post_init__(self) -> None:
        check_int("mu-plus-one mu", self.mu, 2, 100_000)
        check_int("mu-plus-one tau", self.tau, 1, 1_000_000)
        check_int("mu-plus-one recovery", self.recovery, 0, 1_000_000)
        check_int("mu-plus-one evaluations", self.evaluations, 1, 10_000_000)
        if isinstance(self.reevaluation, bool) or not 0.0 <= self.reevaluation <= 1.0:
            raise ValueError(
                f"mu-plus-one reevaluation must be in [0, 1], got {self.reevaluation!r}"
            )
        check_positive("mu-plus-one sigma_min", self.sigma_min)
        check_positive("mu-plus-one sigma_max", self.sigma_max)
        if self.sigma_max < self.sigma_min:
            raise ValueError("mu-plus-one sigma_max must be >= sigma_min")
        check_positive("mu-plus-one init_range", self.init_range, allow_zero=True)
        check_positive("mu-plus-one put_back_penalty_m", self.put_back_penalty_m, allow_zero=True)
        check_positive("mu-plus-one end_margin_m", self.end_margin_m, allow_zero=True)
        if self.robot_budget_s is not None:
            check_positive("mu-plus-one robot_budget_s", self.robot_budget_s)


def adapt_sigma(sigma: float, success: bool, config: MuPlusOneConfig) -> float:
    """Mutation step after a child: ``sigma_min`` if it got in, else doubled up to ``sigma_max``."""
    return config.sigma_min if success else min(2.0 * sigma, config.sigma_max)


def combine_fitness(old: float, new: float) -> float:
    """A re-evaluated member's fitness: the mean of its old fitness and the new measurement."""
    return 0.5 * (old + new)


@dataclass(frozen=True)
class Candidate:
    kind: str
    """``"initial"`` (a first evaluation), ``"reevaluate"`` or ``"child"``."""
    index: int
    """Population slot evaluated (initial, reevaluate), -1 for a child."""
    genome: np.ndarray


@dataclass
class OnlineState:
    population: np.ndarray
    """(μ, W) genomes on board."""
    fitness: np.ndarray
    """(μ,) fitness (NaN until first evaluated); higher is better."""
    evaluated: np.ndarray
    """(μ,) times each member was evaluated."""
    sigma: float
    children: int = 0
    accepted: int = 0
    reevaluations: int = 0


def online_init(config: MuPlusOneConfig, rng: np.random.Generator) -> OnlineState:
    w = n_weights(False)
    population = rng.uniform(-config.init_range, config.init_range, size=(config.mu, w))
    return OnlineState(
        population=population,
        fitness=np.full(config.mu, np.nan),
        evaluated=np.zeros(config.mu, dtype=np.int64),
        sigma=config.sigma_min,
    )


def online_ask(state: OnlineState, config: MuPlusOneConfig, rng: np.random.Generator) -> Candidate:
    """What the robot evaluates next: the first member not yet evaluated, else a re-evaluation
    (probability ``reevaluation``, a member drawn uniformly) or a new child."""
    pending = np.flatnonzero(state.evaluated == 0)
    if len(pending):
        i = int(pending[0])
        return Candidate("initial", i, state.population[i].copy())
    if rng.random() < config.reevaluation:
        i = int(rng.integers(len(state.population)))
        return Candidate("reevaluate", i, state.population[i].copy())
    first, second = tournament_select(-state.fitness, 2, 2, rng)
    child = uniform_crossover(state.population[first][None], state.population[second][None], rng)
    child = child[0] + rng.normal(0.0, state.sigma, size=child.shape[1])
    return Candidate("child", -1, child)


def online_tell(
    state: OnlineState, candidate: Candidate, fitness: float, config: MuPlusOneConfig
) -> bool:
    """Record ``candidate``'s measured ``fitness`` (in place); True if a child got in.

    A child replaces the worst member (the first on ties) only if strictly better; either way
    ``sigma`` is adapted (:func:`adapt_sigma`).
    """
    if candidate.kind == "initial":
        state.fitness[candidate.index] = fitness
        state.evaluated[candidate.index] = 1
        return False
    if candidate.kind == "reevaluate":
        i = candidate.index
        state.fitness[i] = combine_fitness(float(state.fitness[i]), fitness)
        state.evaluated[i] += 1
        state.reevaluations += 1
        return False
    worst = int(np.argmin(state.fitness))
    success = bool(fitness > state.fitness[worst])
    if success:
        state.population[worst] = candidate.genome
        state.fitness[worst] = fitness
        state.evaluated[worst] = 1
        state.accepted += 1
    state.children += 1
    state.sigma = adapt_sigma(state.sigma, success, config)
    return success


class OnboardRobot:
    """One rover on one track, driven on and on: never reset to the start.

    The env runs with ``continue_after_end`` (its own episodes, which end at the far end of an
    open track, are not the robot's); this class tracks progress along the centreline itself and
    puts the rover back by hand when both treads leave the felt (see the module docstring).
    """

    def __init__(
        self,
        library: RoadLibrary,
        world_seed: int,
        *,
        track: str = "training",
        preset: str | Preset = "paper",
        end_margin_m: float = 0.4,
    ) -> None:
        self.env = LfDTrackEnv(track=track, preset=preset, max_steps=10**9, continue_after_end=True)
        self.track = self.env.track
        self.frame, info = self.env.reset(seed=world_seed)
        self.pose = np.asarray(info["pose"], dtype=np.float64)
        self.period_s = float(self.env.preset.rover.control_period_s)
        self.end_margin_m = end_margin_m
        probe = Rover(self.env.preset.rover)
        probe.reset((0.0, 0.0, 0.0), np.random.default_rng(0))
        self._treads = probe.tread_points().reshape(-1, 2)  # body frame (the probe at the origin)
        self.driver = RoadDriver(library)
        self._track_progress()
        self.steps = 0
        self.put_backs = 0

    def _track_progress(self) -> None:
        self._tracker = ProgressTracker(self.track)
        self.s = self._tracker.update(self.pose[:2])

    def on_felt(self, pose: np.ndarray) -> bool:
        """Whether any point of either tread lies on the felt at ``pose``."""
        c, s = math.cos(pose[2]), math.sin(pose[2])
        rot = np.array([[c, s], [-s, c]])
        return bool(self.track.on_felt(self._treads @ rot + pose[:2]).any())

    def facing(self) -> int:
        """+1 if the rover faces the track's file direction at its progress, else -1."""
        _, tangent = self.track.point_at(self.s)
        return 1 if math.cos(self.pose[2] - tangent) >= 0.0 else -1

    def put_back_pose(self) -> tuple[float, float, float]:
        """Where a person puts the rover back (see the module docstring)."""
        length = self.track.length_m
        margin = self.end_margin_m
        sign = self.facing()
        s = self.s
        if not self.track.closed:
            if s > length - margin:
                s, sign = length - margin, -1
            elif s < margin:
                s, sign = margin, 1
        point, tangent = self.track.point_at(s)
        heading = tangent if sign > 0 else tangent + math.pi
        heading = math.atan2(math.sin(heading), math.cos(heading))
        return (float(point[0]), float(point[1]), heading)

    def put_back(self) -> None:
        self.frame, info = self.env.reset(options={"pose": self.put_back_pose()})
        self.pose = np.asarray(info["pose"], dtype=np.float64)
        self._track_progress()
        self.put_backs += 1

    def drive(self, weights: np.ndarray, steps: int) -> tuple[float, int]:
        """Drive ``steps`` commands with ``weights``: (progress [m] in the way the rover faced at
        each command, times put back)."""
        self.driver.use(weights)
        gain = 0.0
        put = 0
        for _ in range(steps):
            sign = self.facing()
            self.frame, _, _, _, info = self.env.step(self.driver.command(self.frame))
            self.steps += 1
            self.pose = np.asarray(info["pose"], dtype=np.float64)
            s = self._tracker.update(self.pose[:2])
            gain += sign * (s - self.s)
            self.s = s
            if not self.on_felt(self.pose):
                self.put_back()
                put += 1
        return gain, put

    @property
    def robot_s(self) -> float:
        return round(self.steps * self.period_s, 6)

    def close(self) -> None:
        self.env.close()


@dataclass
class OnlineResult:
    best_weights: np.ndarray
    best_fitness: float
    curve: list[dict[str, float]]
    """Per evaluation: robot_s (cumulative), kind, fitness measured, population best and mean,
    sigma."""
    robot_s: float
    steps: int
    evaluations: int
    put_backs: int
    children: int
    accepted: int
    reevaluations: int
    world_seed: int
    final_fitness: list[float] = field(default_factory=list)


def mu_plus_one_online(
    library: RoadLibrary,
    config: MuPlusOneConfig,
    seed: int,
    *,
    track: str = "training",
    preset: str | Preset = "paper",
    progress: Callable[[dict[str, Any]], None] | None = None,
) -> OnlineResult:
    """(μ+1)-ONLINE on one robot on ``track`` in one world drawn from ``seed`` (see the module
    docstring).

    The controller returned is the population member with the highest fitness at the end.
    """
    evo_seq, world_seq = np.random.SeedSequence(seed).spawn(2)
    rng = np.random.default_rng(evo_seq)
    world_seed = int(np.random.default_rng(world_seq).integers(0, 2**31))
    robot = OnboardRobot(
        library, world_seed, track=track, preset=preset, end_margin_m=config.end_margin_m
    )
    state = online_init(config, rng)
    curve: list[dict[str, Any]] = []
    for n in range(1, config.evaluations + 1):
        candidate = online_ask(state, config, rng)
        robot.drive(candidate.genome, config.recovery)
        gain, put = robot.drive(candidate.genome, config.tau)
        fitness = gain - config.put_back_penalty_m * put
        online_tell(state, candidate, fitness, config)
        known = state.fitness[state.evaluated > 0]
        point = {
            "evaluation": n,
            "robot_s": robot.robot_s,
            "kind": candidate.kind,
            "fitness": round(float(fitness), 6),
            "best": round(float(known.max()), 6),
            "mean": round(float(known.mean()), 6),
            "sigma": state.sigma,
            "put_backs": robot.put_backs,
        }
        curve.append(point)
        if progress is not None:
            progress(point)
        if config.robot_budget_s is not None and robot.robot_s >= config.robot_budget_s:
            break
    robot.close()
    best = int(np.nanargmax(state.fitness))
    return OnlineResult(
        best_weights=state.population[best].copy(),
        best_fitness=float(state.fitness[best]),
        curve=curve,
        robot_s=robot.robot_s,
        steps=robot.steps,
        evaluations=len(curve),
        put_backs=robot.put_backs,
        children=state.children,
        accepted=state.accepted,
        reevaluations=state.reevaluations,
        world_seed=world_seed,
        final_fitness=[float(f) for f in state.fitness],
    )
