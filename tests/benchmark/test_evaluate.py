"""``lfd_track.evaluate`` / ``lfd-track evaluate``: anyone's policy scored with the benchmark's
own trials. Our controller scores exactly what the benchmark scored it; a hand-written function
and a ``predict``-style object drive (an ``act``-style one is called too); the command writes the report, the plot and
results.json; a policy's fault is one line naming it, and leaves an earlier output as it was."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from lfd_test_support import snapshot

import lfd_track
from lfd_track.benchmark import evaluation, runner
from lfd_track.benchmark.tables import build_results
from lfd_track.cli import main
from lfd_track.demo.demonstrator import HumanConfig
from lfd_track.errors import LfdTrackError
from lfd_track.learning.ga import GAConfig
from lfd_track.policy.controller import Controller

OPEN_TRACK = Path(__file__).resolve().parents[2] / "tracks" / "training.toml"
SEED = 7
#: A quick benchmark (a short demonstration, 10 generations) with two runs per direction, so
#: the later runs of a direction (drawn from the env's own stream) are compared too.
QUICK = runner.BenchmarkConfig(
    repetitions=1,
    trials_per_direction=2,
    seed=SEED,
    human=HumanConfig(legs=1),
    ga=GAConfig(generations=10),
)
COUNTED = ("training_track", "testing_track", "outcomes")


@pytest.fixture(scope="module")
def benchmarked(tmp_path_factory):
    """(controller file, the benchmark's outcomes of it) of a quick benchmark run."""
    work = tmp_path_factory.mktemp("benchmark")
    (rep,) = runner.run_benchmark(QUICK, work, workers=1)
    return work / "rep_00" / "controller.json", rep.outcomes


def _key(outcomes):
    return [
        (o.track, o.direction, o.trial, o.steps, o.failure, o.corners_negotiated) for o in outcomes
    ]


def test_our_controller_scores_exactly_as_the_benchmark_scored_it(benchmarked):
    path, expected = benchmarked
    scored = lfd_track.evaluate(str(path), laps=2, seed=SEED)
    assert scored.outcomes == expected  # every field but the trajectory
    assert _key(scored.outcomes) == _key(expected)
    ours = build_results(expected, repetitions=1, seed=SEED, timing_s={})
    ours = json.loads(json.dumps(ours))
    for key in COUNTED:
        assert scored.results[key] == ours[key]
    # A Controller object scores the same, and fewer laps are the same first laps.
    first = evaluation.evaluate(Controller.load(path), laps=1, seed=SEED, tracks=("testing",))
    assert first.outcomes == [o for o in expected if o.track == "testing" and o.trial == 0]
    # Another seed draws other worlds.
    assert evaluation.trial_seed(SEED) != evaluation.trial_seed(SEED + 1)


def test_the_command_writes_the_report_the_plot_and_the_results(benchmarked, tmp_path, capsys):
    path, expected = benchmarked
    out = tmp_path / "scored"
    argv = ["--quiet", "evaluate", "--policy", str(path), "--laps", "2", "--seed", str(SEED)]
    argv += ["--tracks", "testing"]
    expected = [o for o in expected if o.track == "testing"]
    assert main([*argv, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "Table 2" in printed and "Wilson 95 % intervals" in printed
    assert sorted(p.name for p in out.iterdir()) == [
        "report.md",
        "results.json",
        "trajectories.csv",
        "trajectories.png",
    ]
    results = json.loads((out / "results.json").read_text(encoding="utf-8"))
    assert results["outcomes"] == [o.to_dict() for o in expected]
    assert results["evaluation"]["policy"] == str(path)
    rates = results["rates"]
    successes = sum(o.success for o in expected)
    assert rates["testing"]["all"]["successes"] == rates["all"]["successes"] == successes
    assert rates["testing"]["all"]["trials"] == 4 and "training" not in rates
    low, high = rates["testing"]["all"]["ci95"]
    assert 0.0 <= low <= successes / 4 <= high <= 1.0
    report = (out / "report.md").read_text(encoding="utf-8")
    assert report.startswith("# Corner-success evaluation\n")
    assert "**Table 3** — testing track, laps starting at corner 4." in report
    assert (out / "trajectories.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # The report can be drawn again from results.json alone.
    again = evaluation.write_evaluation_report(tmp_path, results).read_text(encoding="utf-8")
    assert again == report


def test_a_hand_written_function_on_frames(tmp_path):
    seen = []

    def forward(frame):
        seen.append((frame.shape, frame.dtype, frame.flags.writeable))
        return 0

    scored = evaluation.evaluate(forward, tracks=("testing",), laps=1, seed=0)
    assert [(o.track, o.direction) for o in scored.outcomes] == [
        ("testing", "ccw"),
        ("testing", "cw"),
    ]
    # Laps start at corner 4, so each direction meets corner 4 last.
    assert [o.corner_order[-1] for o in scored.outcomes] == ["4", "4"]
    assert set(seen) == {((480, 640, 3), np.dtype(np.uint8), False)}
    assert len(seen) == sum(o.steps for o in scored.outcomes)
    assert scored.policy.endswith("forward") and scored.trials == 2
    assert scored.results["rates"]["testing"]["all"]["trials"] == 2
    assert "training" not in scored.results["rates"]


class Agent:
    """SB3-style: ``predict`` returns ``(action, state)`` and takes ``deterministic``."""

    def __init__(self):
        self.resets = 0
        self.observations = []
        self.deterministic = []

    def reset(self):
        self.resets += 1

    def predict(self, obs, state=None, episode_start=None, deterministic=False):
        self.observations.append(obs)
        self.deterministic.append(deterministic)
        return np.array(0), state


def test_a_predict_object_on_road_values(benchmarked):
    path, _ = benchmarked
    agent = Agent()
    scored = evaluation.evaluate(
        agent, tracks=("testing",), laps=1, observation="road-values", library=path
    )
    assert agent.resets == 2 and all(agent.deterministic)
    assert {(o.shape, o.dtype) for o in agent.observations} == {((40,), np.dtype(np.float32))}
    assert all(np.abs(o).max() <= 1.0 for o in agent.observations)
    assert scored.results["evaluation"]["library"] == str(path)


POLICIES = """
import numpy as np

def raises(obs):
    raise RuntimeError("no idea\\nsecond line")

def three(obs):
    return 3

def half(obs):
    return 1.5

def nothing(obs):
    return None

def yes(obs):
    return True

def pair(obs):
    return np.array([0, 1])

class Agent:
    def predict(self, obs):
        return 0, None

class Actor:
    def act(self, obs):
        return np.int64(7)

actor = Actor()

later = iter(range(10**6))

def late(obs):
    if next(later) == 4:
        raise ValueError("lost")
    return 0
"""


@pytest.fixture
def policies(tmp_path, monkeypatch):
    (tmp_path / "policies.py").write_text(textwrap.dedent(POLICIES), encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    yield "policies.py"
    sys.modules.pop("policies", None)


@pytest.mark.parametrize(
    ("spec", "extra", "problem"),
    [
        ("policies.py:raises", (), "raised RuntimeError: no idea (step 1 of lap 1 on the testing"),
        ("policies.py:three", (), "returned 3; an action is 0 (forward), 1 (left) or 2 (right)"),
        ("policies.py:half", (), "returned 1.5;"),
        ("policies.py:nothing", (), "returned None;"),
        ("policies.py:yes", (), "returned True;"),
        ("policies.py:pair", (), "returned an array of shape (2,) and dtype int64;"),
        ("policies:actor", (), "returned 7 (int64);"),  # act() is what was called
        ("policies:Agent", (), "is a class; name an instance of it"),
        ("policies:missing", (), "policies has no attribute 'missing'"),
        ("nowhere:policy", (), "importing nowhere failed: ModuleNotFoundError"),
        ("policies", (), "name a controller file (.json) or a callable as module:name"),
        ("policies:three", ("--observation", "road-values"), "needs a road library"),
        ("policies:three", ("--library", "x.json"), "only with observation 'road-values'"),
    ],
)
def test_a_faulty_policy_fails_in_one_line_naming_it(policies, spec, extra, problem, capsys):
    argv = ["--quiet", "evaluate", "--policy", spec, "--tracks", "testing", "--laps", "1"]
    assert main([*argv, *extra]) == 1
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1
    assert captured.err.startswith(f"lfd-track evaluate: policy '{spec}': ")
    assert problem in captured.err


def test_bad_arguments_fail_in_one_line(policies, benchmarked, tmp_path, capsys):
    path, _ = benchmarked
    cases = [
        (["--policy", str(path), "--observation", "road-values"], "reads frames through its own"),
        (
            ["--policy", "policies:three", "--tracks", "testing", str(OPEN_TRACK)],
            "not a loop",
        ),
        (["--policy", "policies:three", "--tracks", "testing", "testing"], "a track twice"),
        (["--policy", "missing.json"], "missing.json"),
        (
            ["--policy", "policies:three", "--observation", "road-values", "--library", "x.txt"],
            "a road library comes from a controller file (.json) or a demonstration (.lfdemo)",
        ),
    ]
    for args, problem in cases:
        assert main(["--quiet", "evaluate", *args]) == 1, args
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and problem in err, (args, err)
    with pytest.raises(ValueError, match="observation must be one of frames, road-values"):
        evaluation.evaluate(lambda obs: 0, observation="pixels")
    with pytest.raises(ValueError, match="laps"):
        evaluation.evaluate(lambda obs: 0, laps=0)
    with pytest.raises(LfdTrackError, match="empty"):
        evaluation.load_library(lfd_track.RoadLibrary())


def test_a_policy_failing_mid_run_leaves_the_earlier_output(policies, tmp_path, capsys):
    out = tmp_path / "scored"
    argv = ["--quiet", "evaluate", "--tracks", "testing", "--laps", "1", "--out", str(out)]
    assert main([*argv, "--policy", "policies:three"]) == 1  # nothing written, no folder made
    assert not out.exists()
    out.mkdir()
    (out / "report.md").write_text("mine")
    before = snapshot(out)
    around = sorted(p.name for p in tmp_path.iterdir())
    assert main([*argv, "--policy", "policies.py:late"]) == 1
    err = capsys.readouterr().err
    assert "raised ValueError: lost (step 5 of lap 1 on the testing track" in err
    assert snapshot(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == around


def test_evaluate_is_exported_lazily():
    assert lfd_track.evaluate is evaluation.evaluate
    code = "import sys, lfd_track; print('lfd_track.benchmark.evaluation' in sys.modules)"
    shown = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=Path.cwd()
    )
    assert shown.stdout.strip() == "False"


def test_the_command_has_help(capsys):
    with pytest.raises(SystemExit) as stopped:
        main(["evaluate", "--help"])
    assert stopped.value.code == 0
    shown = " ".join(capsys.readouterr().out.split())
    assert "--policy POLICY" in shown and "Wilson 95 % intervals" in shown
    assert "(default: training testing)" in shown


def test_a_loops_runs_do_not_depend_on_the_other_tracks_driven():
    def forward(obs):
        return 0

    alone = evaluation.evaluate(forward, tracks=("sbend",), laps=1, seed=3)
    both = evaluation.evaluate(forward, tracks=("testing", "sbend"), laps=1, seed=3)
    assert [o.track for o in alone.outcomes] == ["sbend", "sbend"]
    assert alone.outcomes == [o for o in both.outcomes if o.track == "sbend"]
    assert set(alone.results["test_tracks"]) == {"sbend"}
