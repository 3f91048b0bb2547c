"""``lfd-track teach --online --online-learner bc``: backprop learns while the person teaches (the
learner of the goal taught by the paper's human model), the GA stays the default."""

from __future__ import annotations

import json

import pytest
from lfd_test_support import wait_until
from websockets.sync.client import connect

from lfd_track.cli import main
from lfd_track.dataset import load_demonstration
from lfd_track.learning.bc import BCConfig
from lfd_track.teaching.learner_feed import BCLearnerFeed, GALearnerFeed


def _teach(station, commands: list[str]) -> dict:
    """Tap each command over the page's WebSocket; the status once the last is recorded."""
    session = station.session
    with connect(station.url.replace("http", "ws") + "ws", proxy=None, max_queue=None) as ws:
        for given, command in enumerate(commands, start=1):
            ws.send(json.dumps({"type": "press", "command": command}))
            ws.send(json.dumps({"type": "release"}))
            status = wait_until(
                lambda given=given: (
                    (s := session.status())["cases"] == given
                    and not session.commander.pending
                    and not s["driving"]
                    and s
                ),
                f"{given} cases",
            )
    return status


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--online-learner", "bc"], "--online-learner is for --online: give --online"),
        (
            ["--online", "--online-learner", "bc", "--generations-per-case", "3"],
            "--generations-per-case is for --online-learner ga, not bc",
        ),
        (
            ["--online", "--online-learner", "bc", "--population", "20"],
            "--population is for --online-learner ga, not bc",
        ),
        (
            ["--online", "--online-learner", "bc", "--mutation-delta", "0.2"],
            "--mutation-delta is for --online-learner ga, not bc",
        ),
        (["--mirror"], "--mirror is for --online (the learner's cases): give --online"),
        (
            ["--online", "--bc-class-balance", "0.5"],
            "--bc-class-balance is for --online --online-learner bc",
        ),
        (
            ["--online", "--bc-ensemble", "5"],
            "--bc-ensemble is for --online --online-learner bc",
        ),
    ],
)
def test_the_online_learner_flag_is_refused_where_it_means_nothing(
    tmp_path, capsys, flags, message
):
    out = tmp_path / "t.lfdemo"
    assert main(["teach", *flags, "--out", str(out)]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err
    assert not out.exists()


def test_online_teaching_by_backprop_refits_the_map_only_network_after_every_case(open_station):
    """The goal's chosen policy kind (the fresh_felt map read alone, a 3-5-3 network with
    biases, 38 weights) learned by backprop as the person teaches: epochs_per_case epochs after
    each case; the recording names the learner."""
    flags = ["--memory", "fresh_felt", "--features", "none", "--ga-bias"]
    station = open_station("--online", "--online-learner", "bc", *flags)
    session = station.session
    status = _teach(station, ["forward", "forward", "left", "forward"])
    feed = session.learner
    assert isinstance(feed, BCLearnerFeed)
    assert status["generation"] == 4 * feed.epochs_per_case == feed.generation
    assert 0.0 <= status["best_fitness"] <= 1.0
    assert feed.weights.shape == (38,) and session.policy.weights.shape == (38,)
    session.close()
    settings = load_demonstration(station.out).metadata["online_settings"]
    assert settings["learner"] == "bc" and settings["epochs_per_case"] == feed.epochs_per_case
    assert "class_balance" not in settings  # the default case weights: as before the setting


def test_online_teaching_keeps_the_ga_by_default(open_station):
    station = open_station("--online", "--population", "10")
    session = station.session
    _teach(station, ["forward", "left"])
    assert isinstance(session.learner, GALearnerFeed)
    session.close()
    settings = load_demonstration(station.out).metadata["online_settings"]
    assert "learner" not in settings and "epochs_per_case" not in settings
    assert "mirror" not in settings  # off: the recording reads as it always did


def test_online_teaching_with_mirror_fits_each_case_and_its_mirror_image(open_station):
    """``--mirror``: the learner fits the cases and their mirror images, as the benchmark's
    chosen human-taught configuration does; the recording holds only the cases as taught. With
    that configuration's case weights (``--bc-class-balance 0.5``), recorded with the settings."""
    flags = ["--memory", "fresh_felt", "--features", "none", "--ga-bias", "--mirror"]
    station = open_station(
        "--online",
        "--online-learner",
        "bc",
        *flags,
        "--bc-class-balance",
        "0.5",
        "--bc-ensemble",
        "5",
    )
    session = station.session
    _teach(station, ["left", "left", "forward"])
    feed = session.learner
    assert feed.config == BCConfig(bias=True, class_balance=0.5, ensemble=5)
    assert feed.weights.ndim == 1  # while teaching, the policy that may take over is one network
    x, a = feed.cases.arrays()
    fitted_x, fitted_a = feed.training_set(x, a)
    assert a.tolist() == [1, 1, 0]  # forward 0, left 1, right 2
    assert fitted_a.tolist() == [1, 1, 0, 2, 2, 0]  # then the mirror images: left becomes right
    assert fitted_x.shape == (6, 3)
    # the map's bearing changes side in the mirror; amount and distance stay
    assert fitted_x[3:, 0] == pytest.approx(1.0 - x[:, 0])
    assert fitted_x[3:, 1:] == pytest.approx(x[:, 1:])
    session.close()
    demo = load_demonstration(station.out)
    assert demo.metadata["online_settings"]["mirror"] is True
    assert demo.metadata["online_settings"]["class_balance"] == 0.5
    assert demo.metadata["online_settings"]["ensemble"] == 5
    assert demo.commands.tolist() == [1, 1, 0]


def test_online_teaching_runs_round_17s_learner_on_its_five_map_inputs(open_station):
    """The human-taught goal's round 17 configuration as the person teaches: backprop on the map
    with the branch side (expiring while the rover only pivots) and the turn toward it since it
    was set, mirrored, cases weighed n_e ** -0.5; a 5-5-3 network, both extra inputs recorded."""
    flags = ["--memory", "fresh_felt", "--features", "none", "--ga-bias", "--mirror"]
    map_flags = ["--branch-side", "--branch-window", "commands", "--branch-turn"]
    station = open_station(
        "--online", "--online-learner", "bc", *flags, *map_flags, "--bc-class-balance", "0.5"
    )
    session = station.session
    _teach(station, ["forward", "forward", "left", "forward"])
    feed = session.learner
    assert isinstance(feed, BCLearnerFeed)
    assert feed.weights.shape == (5 * 5 + 5 + 5 * 3 + 3,)
    x, a = feed.cases.arrays()
    fitted_x, _ = feed.training_set(x, a)
    assert fitted_x.shape == (8, 5)
    assert fitted_x[4:, 3] == pytest.approx(1.0 - x[:, 3])  # the side changes side
    assert fitted_x[4:, 4] == pytest.approx(x[:, 4])  # the turn toward it does not
    session.close()
    demo = load_demonstration(station.out)
    assert demo.metadata["memory"]["branch_turn"] is True
    assert demo.policy_inputs("none").shape == (4, 5)
