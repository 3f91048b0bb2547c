"""Every integer setting of a benchmark has a generous upper bound: an absurd number (a typo, a
10**400) is refused at once in one line naming the setting, instead of hanging or running out of
memory."""

from __future__ import annotations

import time

import pytest

from lfd_track.benchmark.runner import (
    MAX_REPETITIONS,
    MAX_SEED,
    MAX_TRIALS_PER_DIRECTION,
    MAX_WORKERS,
    BenchmarkConfig,
    run_benchmark,
)
from lfd_track.learning.bc import BCConfig
from lfd_track.learning.cmaes import CMAESConfig
from lfd_track.learning.ga import GAConfig
from lfd_track.methods import HGDaggerConfig, OnlineConfig

BIG = 10**400

TOO_BIG = [
    (BenchmarkConfig, "repetitions", 10**12),
    (BenchmarkConfig, "repetitions", MAX_REPETITIONS + 1),
    (BenchmarkConfig, "repetitions", BIG),
    (BenchmarkConfig, "trials_per_direction", MAX_TRIALS_PER_DIRECTION + 1),
    (BenchmarkConfig, "trials_per_direction", BIG),
    (BenchmarkConfig, "seed", 2**32),
    (BenchmarkConfig, "seed", BIG),
    (BenchmarkConfig, "seed", -1),
    (BenchmarkConfig, "seed", -BIG),
    (GAConfig, "population_size", 100_001),
    (GAConfig, "population_size", BIG),
    (GAConfig, "generations", 1_000_001),
    (GAConfig, "generations", BIG),
    (GAConfig, "tournament_size", 10**12),
    (OnlineConfig, "generations_per_case", BIG),
    (OnlineConfig, "window", BIG),
    (HGDaggerConfig, "rounds", BIG),
    (BCConfig, "epochs", BIG),
    (BCConfig, "batch_size", BIG),
    (CMAESConfig, "population_size", BIG),
    (CMAESConfig, "generations", BIG),
]


@pytest.mark.parametrize(("cls", "name", "value"), TOO_BIG)
def test_absurd_integer_settings_are_refused_in_one_short_line(cls, name, value):
    start = time.perf_counter()
    with pytest.raises(ValueError) as exc:
        cls(**{name: value})
    assert time.perf_counter() - start < 1.0
    message = str(exc.value)
    assert name in message and "\n" not in message, message
    assert len(message) < 200, message  # a 401-digit number is not printed whole


def test_the_limits_are_generous():
    config = BenchmarkConfig(
        repetitions=MAX_REPETITIONS,
        trials_per_direction=MAX_TRIALS_PER_DIRECTION,
        seed=MAX_SEED,
        ga=GAConfig(population_size=100_000, generations=1_000_000, tournament_size=100_000),
    )
    assert (config.repetitions, config.trials_per_direction) == (10_000, 1_000)
    assert config.seed == 2**32 - 1 and config.ga.generations == 1_000_000
    assert OnlineConfig(generations_per_case=10_000).generations_per_case == 10_000
    assert HGDaggerConfig(rounds=1_000).rounds == 1_000
    assert BCConfig(epochs=1_000_000).epochs == 1_000_000
    assert CMAESConfig(population_size=100_000, generations=1_000_000).generations == 1_000_000


@pytest.mark.parametrize("value", [True, 2.0, "3"])
def test_benchmark_counts_must_be_integers(value):
    with pytest.raises(ValueError, match="repetitions must be an integer"):
        BenchmarkConfig(repetitions=value)


@pytest.mark.parametrize("workers", [0, MAX_WORKERS + 1, 10**12, BIG])
def test_run_benchmark_refuses_absurd_worker_counts_at_once(tmp_path, workers):
    start = time.perf_counter()
    with pytest.raises(ValueError, match="workers") as exc:
        run_benchmark(BenchmarkConfig(repetitions=1), tmp_path / "work", workers=workers)
    assert time.perf_counter() - start < 1.0 and len(str(exc.value)) < 200
    assert not (tmp_path / "work").exists()
