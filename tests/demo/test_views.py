"""Shifted and turned views: rendered like any frame, from the pose one command before each case,
labelled with that command, without changing the demonstration or the world."""

from __future__ import annotations

import copy
import dataclasses
import json
import math

import numpy as np
import pytest

from lfd_track.benchmark.runner import BenchmarkConfig, config_dict
from lfd_track.cli import main
from lfd_track.core.commands import Command
from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import run_demonstration
from lfd_track.demo.views import VIEW_LABELS, ViewCases, pose_before
from lfd_track.envs.presets import load_preset
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.learning.bc import BCConfig
from lfd_track.methods.baseline import learn_baseline
from lfd_track.policy.memory import FreshFeltConfig, FreshFeltMemory, memory_config, memory_for
from lfd_track.teaching.scripted import HumanConfig

MAP = FreshFeltConfig.plain(blank_bearing="last", bearing_range_deg=30.0, strip_link_m=0.15)
PICTURE = HumanConfig(steers_by="picture", reaction_delay_prob=0.0, lapse_prob=0.0, legs=1)


def _quiet_preset():
    """The paper preset with a camera whose frames draw nothing at random (no sensor noise, one
    white balance), so two renders of one pose can be compared bit for bit."""
    paper = load_preset("paper")
    sensor = dataclasses.replace(
        paper.sensor, noise_std=0.0, white_balance_pool=1, white_balance_jitter=0.0
    )
    return dataclasses.replace(paper, sensor=sensor)


def test_a_view_from_the_frames_own_pose_is_the_frame():
    env = LfDTrackEnv(track="training", preset=_quiet_preset())
    frame, info = env.reset(seed=3)
    rng = np.random.default_rng(0)
    for command in (0, 0, 1, 0, 2, 0):
        np.testing.assert_array_equal(env.view_from(info["pose"], rng), frame)
        behind = pose_before(np.array(info["pose"]), Command.FORWARD, 0.1, math.radians(22.9))
        assert not np.array_equal(env.view_from(behind, rng), frame)
        frame, _, _, _, info = env.step(command)
    env.close()


def test_views_leave_the_world_and_its_random_streams_as_they_were():
    plain, viewed = LfDTrackEnv(track="testing"), LfDTrackEnv(track="testing")
    a, _ = plain.reset(seed=8)
    b, info = viewed.reset(seed=8)
    rng = np.random.default_rng(1)
    for command in (0, 1, 0, 0, 2, 2, 0):
        np.testing.assert_array_equal(a, b)
        for label in Command:
            viewed.view_from(pose_before(np.array(info["pose"]), label, 0.1, 0.4), rng)
        a, *_ = plain.step(command)
        b, _, _, _, info = viewed.step(command)
    np.testing.assert_array_equal(a, b)
    assert plain.rover_pose.tolist() == viewed.rover_pose.tolist()


def test_pose_before_is_undone_by_the_commands_nominal_motion():
    pose = np.array([1.2, -0.4, 2.5])
    step, pivot = 0.1, math.radians(22.9)
    x, y, theta = pose_before(pose, Command.FORWARD, step, pivot)
    assert theta == pose[2]
    assert x + step * math.cos(theta) == pytest.approx(pose[0], abs=1e-12)
    assert y + step * math.sin(theta) == pytest.approx(pose[1], abs=1e-12)
    assert pose_before(pose, Command.LEFT, step, pivot)[2] == pytest.approx(pose[2] - pivot)
    assert pose_before(pose, Command.RIGHT, step, pivot)[2] == pytest.approx(pose[2] + pivot)


def _driven_map(rng: np.random.Generator) -> FreshFeltMemory:
    memory = FreshFeltMemory(MAP)
    for _ in range(20):
        memory.see(rng.uniform(0.0, 1.0, 40))
        memory.note(int(rng.integers(3)))
    return memory


@pytest.mark.parametrize("command", list(Command))
def test_a_map_placed_one_command_before_comes_back_with_that_command(command):
    """place_before(c) then note(c) gives back the map the rover had: its remembered felt and
    path (plus the place it left) and, shown the same frame, the same inputs."""
    rng = np.random.default_rng(int(command))
    memory = _driven_map(rng)
    placed = copy.copy(memory)
    placed.place_before(command)
    assert not np.allclose(placed._points, memory._points)
    placed.note(command)
    np.testing.assert_allclose(placed._points, memory._points, atol=1e-12)
    np.testing.assert_allclose(placed._path[:-1], memory._path, atol=1e-12)
    values = rng.uniform(0.0, 1.0, 40)
    placed.see(values)
    memory.see(values)
    np.testing.assert_allclose(placed.inputs(), memory.inputs(), atol=1e-9)


def test_memories_of_commands_only_do_not_move_with_the_rover():
    for kind in ("last_bend", "previous_command"):
        memory = memory_for(memory_config({"kind": kind}))
        for command in (1, 1, 0, 2):
            memory.note(command)
        before = memory.inputs()
        memory.place_before(Command.LEFT)
        np.testing.assert_array_equal(memory.inputs(), before)


def test_a_demonstration_with_views_is_the_same_demonstration(tmp_path):
    plain, viewed = tmp_path / "plain.lfdemo", tmp_path / "viewed.lfdemo"
    run_demonstration(plain, seed=5, human=PICTURE, memory=MAP, fsync=False)
    views = ViewCases()
    run_demonstration(viewed, seed=5, human=PICTURE, memory=MAP, fsync=False, views=views)
    a, b = load_demonstration(plain), load_demonstration(viewed)
    np.testing.assert_array_equal(a.inputs, b.inputs)
    np.testing.assert_array_equal(a.commands, b.commands)
    # Every case gets its views in order: the forward one, then the turned ones not skipped.
    expected = [int(label) for c in a.commands for label in VIEW_LABELS[Command(int(c))]]
    assert views.labels == expected
    assert views.policy_inputs("none").shape == (len(expected), 3)
    assert views.policy_inputs().shape == (len(expected), 43)
    assert views.policy_inputs("road_values+colour").shape == (len(expected), 163)
    x = views.policy_inputs("none")
    assert np.isfinite(x).all() and (x >= 0).all() and (x <= 1).all()
    # A view turned right of the case (label left) sees the felt further left than one turned
    # left (label right): the map's bearing input (above 0.5: to the left) says so on average.
    labels = views.commands
    assert x[labels == Command.LEFT, 0].mean() > x[labels == Command.RIGHT, 0].mean() + 0.2


def test_bc_learns_from_the_views_and_the_run_records_them(tmp_path):
    common = dict(
        demo_seed=5, ga_seed=1, preset="paper", human=PICTURE, memory=MAP, features="none"
    )
    bc = BCConfig(epochs=50)
    plain = learn_baseline(tmp_path / "plain", learner=bc, mirror=True, **common)
    learned = learn_baseline(tmp_path, learner=bc, mirror=True, shifted_views=True, **common)
    demo = load_demonstration(tmp_path / "demonstration.lfdemo")
    counts = learned.demo["views"]
    assert sum(counts.values()) == sum(len(VIEW_LABELS[Command(int(c))]) for c in demo.commands)
    assert counts["forward"] == demo.n_cases
    assert "views" not in plain.demo
    assert learned.effort == plain.effort  # views are no human commands
    # The same demonstration and learner seed: only the views make the fits differ.
    assert learned.demo["cases"] == plain.demo["cases"]
    assert not np.allclose(learned.controller.weights, plain.controller.weights)


def test_shifted_views_are_an_option_of_the_offline_methods():
    assert config_dict(BenchmarkConfig(method="bc", shifted_views=True))["shifted_views"] is True
    assert config_dict(BenchmarkConfig())["shifted_views"] is False  # every setting is written
    for method in ("online", "hg-dagger", "dagger"):
        with pytest.raises(ValueError, match="shifted_views applies to the methods paper"):
            BenchmarkConfig(method=method, shifted_views=True)


def test_benchmark_takes_shifted_views_from_the_command_line(tmp_path):
    out = tmp_path / "bench"
    argv = ["--quiet", "benchmark", "--quick", "--workers", "1", "--out", str(out)]
    assert main([*argv, "--shifted-views"]) == 0
    results = json.loads((out / "results.json").read_text())
    assert results["config"]["shifted_views"] is True
    assert set(results["demonstrations"][0]["views"]) == {"forward", "left", "right"}
    assert "views one command before it" in (out / "report.md").read_text()
