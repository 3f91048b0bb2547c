"""The learning methods of the benchmark: paper unchanged, online takeover, hg-dagger rounds."""

import dataclasses
import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
from lfd_test_support import PerturbedBLAS

from lfd_track.benchmark.runner import (
    BenchmarkConfig,
    repetition_seeds,
    run_benchmark,
    run_repetition,
)
from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import HumanConfig
from lfd_track.learning.bc import BCConfig
from lfd_track.learning.cmaes import CMAESConfig
from lfd_track.learning.ga import GAConfig
from lfd_track.methods import (
    HGDaggerConfig,
    OnlineConfig,
    learn_baseline,
    learn_hg_dagger,
    learn_online,
    learn_paper,
)
from lfd_track.methods.dagger import DaggerConfig
from lfd_track.policy.controller import Controller
from lfd_track.vision.road_library import RoadLibrary


def _seeds(benchmark_seed=0):
    """(demo, ga, trial) seeds of repetition 0, drawn as the runner draws them."""
    rng = np.random.default_rng(repetition_seeds(benchmark_seed, 1)[0])
    return tuple(int(x) for x in rng.integers(0, 2**62, size=3))


#: The quick paper-protocol repetition of these tests: one trial each way, 30 generations.
# The digests below were computed with the renderer's bilinear texture filter (the default of the
# code they pin); its preset keeps them meaningful now that the default is "mipmap".
QUICK_PAPER = BenchmarkConfig(
    repetitions=1, trials_per_direction=1, ga=GAConfig(generations=30), preset="paper_bilinear"
)
QUICK_SEED = 12345


def _digest(array) -> str:
    return hashlib.sha256(np.ascontiguousarray(array).tobytes()).hexdigest()[:16]


def _decisions(result, folder: Path) -> dict:
    """What a repetition decided, none of it rounded by BLAS: the demonstrator's commands, the
    controller's weights (drawn by the GA's generator and chosen by fitness comparisons), every
    trial's outcome and the poses its commands drove (pymunk, no BLAS), the human effort and the
    training accuracy (a count of argmax agreements over the case count)."""
    demo = load_demonstration(folder / "rep_00" / "demonstration.lfdemo")
    controller = Controller.load(folder / "rep_00" / "controller.json")
    return {
        "commands": _digest(demo.commands),
        "weights": _digest(controller.weights),
        "outcomes": [
            (o.direction, o.corners_reached, o.corners_negotiated, o.failure, o.success, o.steps)
            for o in result.outcomes
        ],
        "trajectories": _digest(np.concatenate([o.trajectory for o in result.outcomes])),
        "demo": result.demo,
        "effort": result.effort,
        "training_accuracy": result.training_accuracy,
    }


@pytest.fixture(scope="module")
def quick_paper(tmp_path_factory):
    folder = tmp_path_factory.mktemp("quick_paper")
    result = run_repetition(0, QUICK_SEED, QUICK_PAPER, str(folder))
    return folder, result


def test_paper_repetition_is_unchanged_by_the_loop_refactor(quick_paper):
    # Reference computed with the wave-1 code (separate demonstrator, runner and Controller
    # loops, closed-loop evolve) for this exact configuration. Pinned are the decisions, which
    # every OpenBLAS kernel reproduces (Prescott, Nehalem, Sandybridge, Haswell, one or two
    # threads); the floats that pass through matrix products (fitness values, road values) differ
    # in their last bits from one kernel to another, so they are compared with a tolerance.
    folder, result = quick_paper
    decisions = _decisions(result, folder)
    assert decisions["commands"] == "caf64e57e6050f2c"
    assert decisions["weights"] == "5528548f2339045e"
    assert decisions["outcomes"] == [
        ("direction_1", ("1", "2"), ("1", "2"), None, True, 31),
        ("direction_2", ("2", "1"), ("2", "1"), None, True, 33),
        ("ccw", ("1", "2", "3", "4"), ("1", "2", "3"), "timeout", False, 306),
        ("cw", ("3", "2", "1", "4"), ("3", "2", "1"), "timeout", False, 306),
    ]
    # The poses are computed from the commands alone (pymunk and the C library's sin/cos, no
    # BLAS): bit-identical under every kernel above.
    assert decisions["trajectories"] == "a3f91d6445cadbe5"
    assert result.demo["cases"] == 172
    assert result.training_accuracy == 126 / 172
    # A float, not a decision: the road values it is computed from pass through OpenCV's float32
    # histogram kernels, which OpenCV picks by the processor (an AVX-512 machine gives
    # 0.4529676003616053, 2.8e-7 away, with every decision above the same), and the sums of a
    # few hundred products round differently under each BLAS kernel (from the 15th digit on).
    assert result.fitness_best[-1] == pytest.approx(0.4529673243710729, rel=0, abs=1e-6)
    assert len(result.fitness_best) == 30
    saved = Controller.load(folder / "rep_00" / "controller.json")
    assert saved.learner == "ga" and saved.learner_config == QUICK_PAPER.ga.to_dict()
    assert result.effort == {
        "commands": 182,
        "corrections": 0,
        "takeovers": 0,
        "learning_drive_s": pytest.approx(182 * 0.4),
        "autonomous_drive_s": 0.0,
        "put_backs": 0,
    }


def test_a_repetition_gives_the_same_bytes_twice_in_one_process(quick_paper, tmp_path):
    # Same machine, same versions, same process: the floats too are identical, bit for bit.
    folder, first = quick_paper
    again = run_repetition(0, QUICK_SEED, QUICK_PAPER, str(tmp_path))
    assert _decisions(again, tmp_path) == _decisions(first, folder)
    assert np.asarray(again.fitness_best).tobytes() == np.asarray(first.fitness_best).tobytes()
    for name in ("controller.json", "demonstration.lfdemo"):
        assert (tmp_path / "rep_00" / name).read_bytes() == (folder / "rep_00" / name).read_bytes()


def test_a_repetition_decides_the_same_when_blas_rounds_otherwise(quick_paper, tmp_path):
    """Every result that passes through BLAS (the GA's network outputs, each forward pass, the
    road-value correlations) moved by 1 to 4 ulps, up or down at random: the same commands,
    controller, outcomes and poses; only the fitness values move, by far less than 1e-12."""
    folder, reference = quick_paper
    with PerturbedBLAS(seed=2024, ulps=4) as perturbed:
        result = run_repetition(0, QUICK_SEED, QUICK_PAPER, str(tmp_path))
    # every path was perturbed: the GA's fitness, the training accuracy, the trials' policy (a
    # commander of the teaching loop) and the road values of demonstration and trials
    assert set(perturbed.calls) >= {
        "lfd_track.learning.fitness.population_outputs",
        "lfd_track.learning.fitness.ensemble_forward",
        "lfd_track.teaching.commanders.ensemble_forward",
        "lfd_track.vision.road_library.similarity_matrix",
    }, perturbed.calls
    assert _decisions(result, tmp_path) == _decisions(reference, folder)
    np.testing.assert_allclose(result.fitness_best, reference.fitness_best, rtol=0, atol=1e-12)
    # the perturbation did reach the numbers
    assert not np.array_equal(result.fitness_mean, reference.fitness_mean)


@pytest.fixture(scope="module")
def online_run(tmp_path_factory):
    demo_seed, ga_seed, _ = _seeds(0)
    out = tmp_path_factory.mktemp("online")
    learned = learn_online(
        out,
        demo_seed=demo_seed,
        ga_seed=ga_seed,
        preset="paper",
        human=HumanConfig(),
        ga=GAConfig(),
        online=OnlineConfig(),
    )
    return out, learned


def test_online_takes_over_and_learns_flagged_corrections(online_run):
    out, learned = online_run
    effort = learned.effort
    assert effort["takeovers"] >= 1 and effort["autonomous_drive_s"] > 0
    assert effort["corrections"] >= 1
    # The watching human stepped in by its rule, not only at the turn-arounds (always the
    # human's): every correction has one reason, and at least one is not a turn-around.
    reasons = learned.demo["interventions"]
    assert sum(reasons.values()) == effort["corrections"]
    assert sum(n for why, n in reasons.items() if why != "turn") >= 1
    demo = load_demonstration(out / "demonstration.lfdemo")
    flagged = demo.metadata["correction_cases"]
    assert len(flagged) == learned.demo["correction_cases"] >= 1
    assert all(demo.phases[i] == "correction" for i in flagged)
    # Cases are only what the human gave: fewer than the commands the robot executed.
    assert demo.n_cases < effort["learning_drive_s"] / 0.4
    # The GA ran generations_per_case generations for every case, and the controller is the best.
    assert learned.demo["generations"] == 2 * demo.n_cases
    assert learned.fitness_best and learned.training_accuracy > 0.5
    # careful training holds while the policy drives too: frames off the felt are never learned
    assert learned.demo["off_felt_frames"] > 0 and learned.demo["learned_off_felt"] == 0


def test_online_cases_carry_their_source_and_the_file_logs_its_library(online_run, tmp_path):
    out, learned = online_run
    path = out / "demonstration.lfdemo"
    demo = load_demonstration(path)
    flagged = demo.metadata["correction_cases"]
    assert flagged and np.flatnonzero(demo.sources == "correction").tolist() == flagged
    assert set(demo.sources.tolist()) == {"demonstration", "correction"}
    assert (demo.rounds == 0).all()
    assert demo.metadata["library_log"]
    # an interrupted recording still carries the library it was recorded with
    data = path.read_bytes()
    cut = tmp_path / "cut.lfdemo"
    cut.write_bytes(data[: len(data) // 2])
    partial = load_demonstration(cut)
    assert not partial.metadata["complete"] and partial.n_cases > 0
    assert RoadLibrary.from_dict(partial.metadata["road_library"]).n_models > 0
    assert learned.controller.learner == "online"
    assert learned.controller.learner_config == {
        **OnlineConfig().to_dict(),
        "ga": GAConfig().to_dict(),
    }


def test_online_is_deterministic(online_run, tmp_path):
    _, first = online_run
    demo_seed, ga_seed, _ = _seeds(0)
    again = learn_online(
        tmp_path,
        demo_seed=demo_seed,
        ga_seed=ga_seed,
        preset="paper",
        human=HumanConfig(),
        ga=GAConfig(),
        online=OnlineConfig(),
    )
    np.testing.assert_array_equal(again.controller.weights, first.controller.weights)
    assert again.effort == first.effort


def test_hg_dagger_adds_intervention_cases_every_round(tmp_path):
    demo_seed, ga_seed, _ = _seeds(0)
    kwargs = dict(demo_seed=demo_seed, ga_seed=ga_seed, preset="paper", human=HumanConfig())
    hg = HGDaggerConfig(rounds=2)
    learned = learn_hg_dagger(tmp_path / "a", **kwargs, ga=GAConfig(generations=20), hg=hg)
    rounds = learned.demo["rounds"]
    assert [r["round"] for r in rounds] == [1, 2]
    assert all(r["intervention_cases"] > 0 for r in rounds)
    # every time the human took control back has one reason of the intervention rule
    assert all(sum(r["interventions"].values()) == r["corrections"] for r in rounds)
    demo_cases = load_demonstration(tmp_path / "a" / "demonstration.lfdemo").n_cases
    assert learned.demo["cases"] == demo_cases + sum(r["intervention_cases"] for r in rounds)
    for r in rounds:
        file = load_demonstration(tmp_path / "a" / f"interventions_r{r['round']}.lfdemo")
        assert file.n_cases == r["intervention_cases"] and file.metadata["round"] == r["round"]
        assert (file.rounds == r["round"]).all() and (file.sources == "correction").all()
    demo = load_demonstration(tmp_path / "a" / "demonstration.lfdemo")
    assert (demo.rounds == 0).all() and (demo.sources == "demonstration").all()
    assert learned.controller.learner == "hg-dagger"
    assert learned.controller.learner_config["rounds"] == 2
    # re-evolved after each round: the GA history holds 1 + R runs
    assert len(learned.fitness_best) == 20 * (1 + len(rounds))
    assert learned.effort["corrections"] >= len(rounds)
    again = learn_hg_dagger(tmp_path / "b", **kwargs, ga=GAConfig(generations=20), hg=hg)
    np.testing.assert_array_equal(again.controller.weights, learned.controller.weights)


def test_hg_dagger_with_memory_keeps_it_in_every_file(tmp_path):
    """Memory runs: the demonstration, each round's interventions and the controller carry the
    memory settings (the demonstration, which holds the road library, evolves on its own)."""
    from lfd_track.cli import main
    from lfd_track.policy.controller import Controller
    from lfd_track.policy.memory import LastBendConfig

    demo_seed, ga_seed, _ = _seeds(0)
    memory = LastBendConfig()
    learned = learn_hg_dagger(
        tmp_path,
        demo_seed=demo_seed,
        ga_seed=ga_seed,
        preset="paper",
        human=HumanConfig(turnarounds="toward_last_bend"),
        ga=GAConfig(generations=10),
        hg=HGDaggerConfig(rounds=1),
        memory=memory,
        mirror=True,
    )
    assert learned.controller.memory == memory
    for name in ("demonstration.lfdemo", "interventions_r1.lfdemo"):
        demo = load_demonstration(tmp_path / name)
        assert demo.metadata["memory"] == memory.to_dict() and demo.memory.shape[1] == 1
    out = tmp_path / "controller.json"
    assert main(["--quiet", "evolve", str(tmp_path / "demonstration.lfdemo"),
                 "--generations", "2", "--out", str(out)]) == 0  # fmt: skip
    assert Controller.load(out).memory == memory


def test_hg_dagger_by_backprop_fits_the_bc_network_again_after_every_round(tmp_path):
    """learner "bc": the bc method's network after the demonstration, then backprop on all cases
    (mirrored too) after each round, on the map alone; the file says so, and the GA's settings
    are not what it used."""
    from lfd_track.learning.bc import BCConfig
    from lfd_track.policy.memory import FreshFeltConfig

    demo_seed, ga_seed, _ = _seeds(0)
    bc = BCConfig(epochs=200, bias=True)
    kwargs = dict(
        demo_seed=demo_seed,
        ga_seed=ga_seed,
        preset="paper",
        human=HumanConfig(clear_memory_per_leg=True),
        memory=FreshFeltConfig(),
        features="none",
        mirror=True,
        bc=bc,
        ga=GAConfig(generations=2),
    )
    hg = HGDaggerConfig(rounds=1, learner="bc")
    learned = learn_hg_dagger(tmp_path / "a", **kwargs, hg=hg)
    (r,) = learned.demo["rounds"]
    assert r["intervention_cases"] > 0
    controller = learned.controller
    assert controller.learner == "hg-dagger" and controller.bias and controller.n_inputs == 3
    assert controller.learner_config == {**hg.to_dict(), "bc": bc.to_dict()}
    assert controller.learner_config["learner"] == "bc"
    # backprop's loss history after the demonstration and after the round, no GA means
    assert len(learned.fitness_best) == 2 * bc.epochs and learned.fitness_mean == []
    again = learn_hg_dagger(tmp_path / "b", **kwargs, hg=hg)
    np.testing.assert_array_equal(again.controller.weights, controller.weights)
    # "ga", the default, is left out of the settings (files written before it still match)
    assert "learner" not in HGDaggerConfig().to_dict()
    assert HGDaggerConfig.from_dict(hg.to_dict()) == hg
    with pytest.raises(ValueError, match="hg-dagger learner must be one of ga, bc"):
        HGDaggerConfig(learner="cma-es")


def test_hg_dagger_and_dagger_by_backprop_learn_an_ensemble(tmp_path):
    """With backprop's ensemble (``BCConfig.ensemble``) the interventions' rounds and DAgger's
    rounds are driven by, and end with, k networks driving by their mean outputs."""
    from lfd_track.learning.bc import BCConfig
    from lfd_track.methods import learn_dagger
    from lfd_track.methods.dagger import DaggerConfig
    from lfd_track.policy.memory import FreshFeltConfig

    demo_seed, ga_seed, _ = _seeds(0)
    bc = BCConfig(epochs=100, bias=True, ensemble=2)
    kwargs = dict(demo_seed=demo_seed, ga_seed=ga_seed, preset="paper", bc=bc)
    learned = learn_hg_dagger(
        tmp_path / "hg",
        **kwargs,
        human=HumanConfig(clear_memory_per_leg=True),
        memory=FreshFeltConfig(),
        features="none",
        mirror=True,
        ga=GAConfig(generations=2),
        hg=HGDaggerConfig(rounds=1, learner="bc"),
    )
    assert learned.controller.members == 2
    assert learned.controller.learner_config["bc"]["ensemble"] == 2
    assert 0.0 <= learned.training_accuracy <= 1.0
    dagger = learn_dagger(
        tmp_path / "dagger",
        **kwargs,
        human=HumanConfig(legs=1),
        ga=GAConfig(generations=2),
        dagger=DaggerConfig(rounds=1, learner="bc"),
    )
    assert dagger.controller.members == 2
    dagger.controller.save(tmp_path / "dagger.json")
    assert Controller.load(tmp_path / "dagger.json").members == 2


def test_method_settings_round_trip_and_refuse_unknown_keys():
    online = OnlineConfig(window=6, threshold=0.5)
    assert OnlineConfig.from_dict(online.to_dict()) == online
    hg = HGDaggerConfig(rounds=5)
    assert HGDaggerConfig.from_dict(hg.to_dict()) == hg
    with pytest.raises(ValueError, match="unknown online setting 'k'"):
        OnlineConfig.from_dict({"k": 3})
    # the nested intervention rule is rebuilt as a config too, and checked the same way
    rebuilt = OnlineConfig.from_dict({"intervention": {"stall_commands": 5}})
    assert rebuilt.intervention.stall_commands == 5
    with pytest.raises(ValueError, match="unknown hg-dagger setting 'stall'"):
        HGDaggerConfig.from_dict({"intervention": {"stall": 5}})
    with pytest.raises(ValueError, match="threshold"):
        dataclasses.replace(online, threshold=0)
    with pytest.raises(ValueError, match="unknown method"):
        BenchmarkConfig(method="magic")


def test_bc_reaches_at_least_the_ga_training_accuracy_on_the_same_cases(tmp_path):
    demo_seed, ga_seed, _ = _seeds(0)
    kwargs = dict(demo_seed=demo_seed, ga_seed=ga_seed, preset="paper", human=HumanConfig())
    paper = learn_paper(tmp_path / "ga", **kwargs, ga=GAConfig())
    bc = learn_baseline(tmp_path / "bc", **kwargs, learner=BCConfig())
    assert bc.demo["cases"] == paper.demo["cases"]  # the same demonstration
    assert bc.demo["learner"] == "bc"
    assert bc.training_accuracy >= paper.training_accuracy
    assert bc.effort == paper.effort  # same human effort: only the learner differs


def test_cma_es_is_wired_in_as_a_method(tmp_path):
    demo_seed, ga_seed, _ = _seeds(0)
    learned = learn_baseline(
        tmp_path,
        demo_seed=demo_seed,
        ga_seed=ga_seed,
        preset="paper",
        human=HumanConfig(legs=1),
        learner=CMAESConfig(generations=5),
    )
    assert learned.demo["learner"] == "cma-es" and len(learned.fitness_best) == 5
    assert learned.controller.weights.shape == (215,)


_QUICK = dict(
    repetitions=1,
    trials_per_direction=1,
    human=HumanConfig(legs=1),
    ga=GAConfig(generations=10),
    online=OnlineConfig(window=4, threshold=0.75),
    hg_dagger=HGDaggerConfig(rounds=1),
    bc=BCConfig(epochs=50),
    cmaes=CMAESConfig(generations=3),
    dagger=DaggerConfig(rounds=1),
)


@pytest.mark.parametrize("method", ["online", "hg-dagger", "bc", "cma-es", "dagger"])
def test_every_method_gives_the_same_results_with_one_or_two_workers(method, tmp_path):
    config = BenchmarkConfig(method=method, **_QUICK)
    one = run_benchmark(config, tmp_path / "one", workers=1)
    two = run_benchmark(config, tmp_path / "two", workers=2)
    for a, b in zip(one, two, strict=True):
        assert a.effort == b.effort and a.demo == b.demo
        assert a.fitness_best == b.fitness_best
        assert [o.to_dict() for o in a.outcomes] == [o.to_dict() for o in b.outcomes]
    first = (tmp_path / "one" / "rep_00" / "controller.json").read_bytes()
    assert first == (tmp_path / "two" / "rep_00" / "controller.json").read_bytes()
    saved = Controller.load(tmp_path / "one" / "rep_00" / "controller.json")
    assert saved.learner == method
    settings = {
        "online": "online",
        "hg-dagger": "hg_dagger",
        "bc": "bc",
        "cma-es": "cmaes",
        "dagger": "dagger",
    }
    expected = getattr(config, settings[method]).to_dict()
    assert {k: saved.learner_config[k] for k in expected} == expected


def test_trial_directions_put_extra_loops_last():
    from lfd_track.benchmark.runner import DIRECTIONS, trial_directions

    assert trial_directions(("testing",)) == list(DIRECTIONS)
    extra = trial_directions(("testing", "loop_x"))
    assert extra[:4] == list(DIRECTIONS)
    assert extra[4:] == [("loop_x", False, "ccw"), ("loop_x", True, "cw")]
    assert [d[0] for d in trial_directions(("loop_x",))] == ["training"] * 2 + ["loop_x"] * 2


def test_extra_test_tracks_are_lapped_both_ways_and_reported_per_track(tmp_path):
    from lfd_track.benchmark.report import write_benchmark_outputs
    from lfd_track.utils.data import resolve_data_file

    text = Path(resolve_data_file("tracks", "testing")).read_text()
    loop = tmp_path / "other_loop.toml"
    loop.write_text(text.replace('name = "testing"', 'name = "other_loop"'))
    config = BenchmarkConfig(
        repetitions=1,
        trials_per_direction=1,
        human=HumanConfig(legs=1),
        ga=GAConfig(generations=5),
        test_tracks=("testing", str(loop)),
    )
    reps = run_benchmark(config, tmp_path / "work")
    tracks = [(o.track, o.direction) for o in reps[0].outcomes]
    assert tracks[-2:] == [(str(loop), "ccw"), (str(loop), "cw")]
    write_benchmark_outputs(tmp_path / "out", config, reps, wall_s=1.0, workers=1)
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    assert results["test_tracks"][str(loop)]["laps"] == 2
    assert results["testing_track"]["laps"] == 2  # the paper's tables keep the testing track
    assert results["method"] == "paper" and results["human_effort"]["total"]["commands"] > 0
    # what computed the numbers: versions and BLAS kernel (lfd_track.utils.provenance)
    assert results["environment"]["numpy"] == np.__version__ and "blas" in results["environment"]
    assert "Extra test loops" in (tmp_path / "out" / "report.md").read_text()
    with pytest.raises(ValueError, match="twice"):
        BenchmarkConfig(test_tracks=("testing", "testing"))


#: An open track with one 90° left corner, short enough for a quick demonstration.
ELBOW = """name = "elbow"
closed = false
width_m = 0.30
vertices = [[0.0, 0.0], [1.2, 0.0], [1.2, 1.2]]
[corners]
"1" = 1
"""


def test_methods_demonstrate_and_drive_on_the_demo_track(tmp_path, monkeypatch):
    """``track`` moves the demonstration (every method) and HG-DAgger's rounds off the paper's
    training track; every env the learning builds is on it."""
    from lfd_track.demo import demonstrator
    from lfd_track.methods import common as methods

    elbow = tmp_path / "elbow.toml"
    elbow.write_text(ELBOW)
    built: list[str] = []

    def spy(cls):
        class Spied(cls):
            def __init__(self, *args, track="training", **kwargs):
                built.append(str(track))
                super().__init__(*args, track=track, **kwargs)

        return Spied

    monkeypatch.setattr(methods, "LfDTrackEnv", spy(methods.LfDTrackEnv))
    monkeypatch.setattr(demonstrator, "LfDTrackEnv", spy(demonstrator.LfDTrackEnv))
    demo_seed, ga_seed, _ = _seeds(0)
    kwargs = dict(demo_seed=demo_seed, ga_seed=ga_seed, preset="paper", human=HumanConfig())
    learned = learn_hg_dagger(
        tmp_path / "hg",
        **kwargs,
        ga=GAConfig(generations=5),
        hg=HGDaggerConfig(rounds=1),
        track=str(elbow),
    )
    demo = load_demonstration(tmp_path / "hg" / "demonstration.lfdemo")
    assert demo.metadata["track"] == str(elbow)
    assert built == [str(elbow)] * 3  # the demonstration, then the round's two directions
    assert learned.controller.learner == "hg-dagger"
    built.clear()
    learn_online(
        tmp_path / "online",
        **kwargs,
        ga=GAConfig(generations=2),
        online=OnlineConfig(generations_per_case=1),
        track=str(elbow),
    )
    assert built == [str(elbow)]
    online = load_demonstration(tmp_path / "online" / "demonstration.lfdemo")
    assert online.metadata["track"] == str(elbow)


def test_an_unknown_demo_track_is_refused_before_anything_runs_and_a_loop_is_taken():
    from lfd_track.benchmark.runner import check_tracks
    from lfd_track.errors import LfdTrackError

    with pytest.raises((ValueError, LfdTrackError), match="no-such-track"):
        check_tracks(BenchmarkConfig(demo_track="no-such-track"))
    with pytest.raises(ValueError, match="demo_track must be"):
        BenchmarkConfig(demo_track="")
    check_tracks(BenchmarkConfig())  # the default, the paper's training track, passes
    check_tracks(BenchmarkConfig(demo_track="testing"))  # a loop: a lap per leg
