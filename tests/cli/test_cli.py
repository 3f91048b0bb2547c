"""The lfd-track command: demo → evolve → drive, the quick benchmark, and user errors."""

from __future__ import annotations

import argparse
import io
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lfd_track.cli import main
from lfd_track.vision.road_library import RoadLibrary


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "lfd_track.cli", "--quiet", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=600,
    )


@pytest.fixture(scope="module")
def controller_file(tmp_path_factory):
    work = tmp_path_factory.mktemp("pipeline")
    demo = work / "demo.lfdemo"
    assert main(["--quiet", "demo", "--seed", "1", "--out", str(demo)]) == 0
    controller = work / "controller.json"
    assert main(["--quiet", "evolve", str(demo), "--seed", "1", "--out", str(controller)]) == 0
    assert controller.with_suffix(".fitness.png").is_file()
    return controller


def test_drive_reports_per_lap_corner_outcomes_as_json(controller_file, capsys, tmp_path):
    plot = tmp_path / "laps.png"
    code = main(
        [
            "--quiet",
            "drive",
            str(controller_file),
            "--track",
            "training",
            "--laps",
            "2",
            "--seed",
            "3",
            "--json",
            "--plot",
            str(plot),
        ]
    )
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    assert len(report["laps"]) == 2
    for lap in report["laps"]:
        assert set(lap) >= {"success", "failure", "corners_reached", "corners_negotiated", "steps"}
        assert lap["success"] == (lap["failure"] is None)
    assert plot.stat().st_size > 1000


def test_drive_video_shows_camera_and_top_down(controller_file, tmp_path, monkeypatch):
    import cv2

    from lfd_track.viz.video import DriveVideo

    captions = []
    real_add = DriveVideo.add

    def add(self, frame, values, info, *, lap=1, command=None):
        captions.append((lap, command))
        real_add(self, frame, values, info, lap=lap, command=command)

    monkeypatch.setattr(DriveVideo, "add", add)
    video = tmp_path / "drive.mp4"
    code = main(
        [
            "--quiet",
            "drive",
            str(controller_file),
            "--track",
            "training",
            "--laps",
            "1",
            "--seed",
            "2",
            "--video",
            str(video),
        ]
    )
    assert code == 0
    cap = cv2.VideoCapture(str(video))
    ok, frame = cap.read()
    assert ok
    assert frame.shape[0] == 480 and frame.shape[1] > 640  # camera view plus the top-down view
    assert cap.get(cv2.CAP_PROP_FRAME_COUNT) >= 5
    # Each frame is captioned with its lap and the command the controller chose for it.
    assert len(captions) == cap.get(cv2.CAP_PROP_FRAME_COUNT)
    assert all(lap == 1 and command in (0, 1, 2) for lap, command in captions)
    cap.release()
    camera_half = cv2.cvtColor(frame[:, :640], cv2.COLOR_BGR2RGB).astype(int)
    # The road-value overlay tints regions green (road) and red (not road) and draws the grid.
    greenish = (camera_half[..., 1] > camera_half[..., 0] + 40) & (
        camera_half[..., 1] > camera_half[..., 2]
    )
    reddish = camera_half[..., 0] > camera_half[..., 1] + 60
    assert greenish.mean() > 0.1 and reddish.mean() > 0.05
    grid_column = camera_half[:, 78:83].mean(axis=(0, 2))
    assert grid_column.min() < camera_half.mean() * 0.7  # a dark grid line near x = 80


def test_quick_benchmark_writes_results_report_and_plots(tmp_path):
    out = tmp_path / "bench"
    proc = run_cli("benchmark", "--quick", "--seed", "4", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "Table 2" in proc.stdout and "Table 3" in proc.stdout
    results = json.loads((out / "results.json").read_text())
    assert results["schema"] == 13 and results["repetitions"] == 1 and results["seed"] == 4
    for key in ("direction_1", "direction_2"):
        section = results["training_track"][key]
        assert section["trials"] == 1 and set(section["corners"]) == {"1", "2"}
    for key in ("cw", "ccw"):
        section = results["testing_track"][key]
        assert section["laps"] == 1 and set(section["corners"]) == {"1", "2", "3", "4"}
    assert results["paper"]["testing_track"]["cw"]["corners"]["2"] == {"reached": 30, "failures": 7}
    assert "timing_s" in results
    for name in ("report.md", "trajectories.png", "fitness.png"):
        assert (out / name).stat().st_size > 500
    assert (out / "repetitions" / "rep_00" / "controller.json").is_file()


def test_benchmark_runs_the_memory_pipeline_from_flags(tmp_path):
    """--memory, --turnarounds and --mirror reach the run, its results and its report."""
    out = tmp_path / "bench"
    argv = ["--quiet", "benchmark", "--quick", "--workers", "1", "--out", str(out)]
    argv += ["--memory", "last_bend", "--turnarounds", "toward_last_bend", "--mirror"]
    assert main(argv) == 0
    results = json.loads((out / "results.json").read_text())
    assert results["config"]["memory"] == {"kind": "last_bend"}
    assert results["config"]["mirror"] is True
    assert results["demonstrations"][0]["turnarounds"] == ["right", "left", "right", "left"]
    controller = json.loads((out / "repetitions" / "rep_00" / "controller.json").read_text())
    assert controller["schema_version"] == 8 and controller["layer_sizes"] == [41, 5, 3]
    assert (
        "**Beyond the paper's pipeline**: the network also reads memory inputs"
        in (out / "report.md").read_text()
    )


def test_benchmark_online_runs_the_goals_chosen_map_from_flags(tmp_path):
    """The goal's chosen map (every option of it a flag) with a network that reads it alone,
    learned by the online method: the settings reach the run and the controller file."""
    out = tmp_path / "bench"
    argv = ["--quiet", "benchmark", "--quick", "--workers", "1", "--out", str(out)]
    argv += ["--method", "online", "--features", "none", "--steers-by", "picture"]
    argv += ["--memory", "fresh_felt", "--blank-bearing", "last", "--bearing-range", "30"]
    argv += ["--strip-link", "0.15", "--blank-reach", "1.0", "--blank-distance", "reach"]
    argv += ["--visited-fade", "0.3", "--strip-picture-links"]
    assert main(argv) == 0
    memory = json.loads((out / "results.json").read_text())["config"]["memory"]
    expected = {"strip_link_m": 0.15, "blank_reach_m": 1.0, "visited_fade_m": 0.3}
    assert memory["strip_picture_links"] is True
    assert {k: memory[k] for k in expected} == expected
    assert memory["blank_distance"] == "reach" and "path_places" not in memory
    controller = json.loads((out / "repetitions" / "rep_00" / "controller.json").read_text())
    assert controller["layer_sizes"] == [3, 5, 3] and controller["memory"] == memory


def _without_timing(path: Path) -> dict:
    data = json.loads(path.read_text())
    data.pop("timing_s")
    return data


def test_benchmark_is_identical_with_one_or_two_workers(tmp_path):
    one, two = tmp_path / "one", tmp_path / "two"
    args = ["benchmark", "--repetitions", "2", "--trials", "1", "--seed", "9"]
    assert run_cli(*args, "--workers", "1", "--out", str(one)).returncode == 0
    assert run_cli(*args, "--workers", "2", "--out", str(two)).returncode == 0
    assert _without_timing(one / "results.json") == _without_timing(two / "results.json")


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["evolve", "MISSING.lfdemo", "--out", "c.json"], "MISSING.lfdemo"),
        (["drive", "MISSING.json"], "MISSING.json"),
        (["drive", "CONTROLLER", "--track", "moon"], "unknown track 'moon'"),
        (["benchmark", "--repetitions", "-3", "--out", "b"], "must be at least 1"),
        (["benchmark", "--steers-by", "picture", "--out", "b"], "set memory kind 'fresh_felt'"),
        (["demo", "--track", "nowhere", "--out", "d.lfdemo"], "unknown track 'nowhere'"),
    ],
)
def test_user_errors_are_one_line_without_traceback(tmp_path, controller_file, args, expected):
    args = [str(controller_file) if a == "CONTROLLER" else a for a in args]
    proc = run_cli(*args, cwd=tmp_path)
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert expected in lines[0]
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "c.json").exists() and not (tmp_path / "b" / "results.json").exists()


def test_truncated_demonstration_and_wrong_schema_controller(tmp_path, controller_file):
    demo = tmp_path / "cut.lfdemo"
    demo.write_bytes(b"LFDEMO\x00\x01garbage")
    proc = run_cli("evolve", str(demo), "--out", str(tmp_path / "c.json"))
    assert proc.returncode == 1 and len(proc.stderr.strip().splitlines()) == 1
    assert str(demo) in proc.stderr and not (tmp_path / "c.json").exists()

    data = json.loads(controller_file.read_text())
    data["schema_version"] = 99
    bad = tmp_path / "future.json"
    bad.write_text(json.dumps(data))
    proc = run_cli("drive", str(bad))
    assert proc.returncode == 1 and len(proc.stderr.strip().splitlines()) == 1
    assert str(bad) in proc.stderr

    truncated = tmp_path / "truncated.json"
    truncated.write_text(controller_file.read_text()[:500])
    proc = run_cli("drive", str(truncated))
    assert proc.returncode == 1 and str(truncated) in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_wrong_schema_demonstration_is_one_line(tmp_path, monkeypatch):
    import numpy as np

    from lfd_track import dataset
    from lfd_track.dataset import records

    bad = tmp_path / "future.lfdemo"
    monkeypatch.setattr(records, "SCHEMA_VERSION", max(dataset.READABLE_SCHEMAS) + 1)
    with dataset.DemonstrationWriter(bad, {"track": "training"}, bins=32, fsync=False) as writer:
        writer.append(0, np.zeros(40), np.zeros((40, 5, 32), np.float32))
    proc = run_cli("evolve", str(bad), "--out", str(tmp_path / "c.json"))
    assert proc.returncode == 1 and len(proc.stderr.strip().splitlines()) == 1
    future = max(dataset.READABLE_SCHEMAS) + 1
    assert str(bad) in proc.stderr and f"unsupported schema version {future}" in proc.stderr
    assert not (tmp_path / "c.json").exists()


def test_a_demonstration_with_an_empty_road_library_is_one_line(tmp_path):
    import numpy as np

    from lfd_track import dataset
    from lfd_track.vision.road_library import RoadLibrary

    bad = tmp_path / "unlearned.lfdemo"
    with dataset.DemonstrationWriter(bad, {"track": "training"}, bins=32, fsync=False) as writer:
        writer.append(0, np.zeros(40), np.zeros((40, 5, 32), np.float32))
        writer.close({"road_library": RoadLibrary().to_dict()})
    proc = run_cli("evolve", str(bad), "--out", str(tmp_path / "c.json"))
    assert proc.returncode == 1 and len(proc.stderr.strip().splitlines()) == 1
    assert str(bad) in proc.stderr and "road library is empty" in proc.stderr
    assert "load_demonstration" not in proc.stderr  # no Python hint to a command-line user
    assert not (tmp_path / "c.json").exists()


def test_evolve_keeps_a_demonstrations_memory_inputs(tmp_path):
    """A demonstration recorded with memory inputs evolves a controller that reads them; one
    whose memory settings do not fit its cases is refused in one line, nothing written."""
    from lfd_track.dataset import DemonstrationWriter
    from lfd_track.policy.controller import Controller
    from lfd_track.policy.memory import LastBendConfig

    rng = np.random.default_rng(0)
    library = RoadLibrary()
    library.learn(rng.integers(0, 255, (480, 640, 3), dtype=np.uint8))
    memory = LastBendConfig()

    def record(path, metadata_memory):
        metadata = {"track": "training", "road_library": library.to_dict()}
        if metadata_memory is not None:
            metadata["memory"] = metadata_memory
        with DemonstrationWriter(path, metadata, bins=32, fsync=False, n_memory=1) as writer:
            for i in range(12):
                writer.append(i % 3, rng.uniform(0, 1, 40), np.zeros((40, 5, 32)), memory=[i % 2])

    good = tmp_path / "memory.lfdemo"
    record(good, memory.to_dict())
    out = tmp_path / "c.json"
    assert main(["--quiet", "evolve", str(good), "--generations", "3", "--out", str(out)]) == 0
    controller = Controller.load(out)
    assert controller.memory == memory and controller.n_inputs == 41

    bad = tmp_path / "no-settings.lfdemo"
    record(bad, None)
    proc = run_cli("evolve", str(bad), "--out", str(tmp_path / "d.json"))
    assert proc.returncode == 1 and len(proc.stderr.strip().splitlines()) == 1
    assert str(bad) in proc.stderr and "bad memory settings" in proc.stderr
    assert not (tmp_path / "d.json").exists()


def test_bad_preset_fails_before_the_benchmark_creates_anything(tmp_path):
    preset = tmp_path / "bad.toml"
    preset.write_text("[camera]\nzoom = 3\n")
    out = tmp_path / "bench"
    proc = run_cli("benchmark", "--quick", "--preset", str(preset), "--out", str(out))
    assert proc.returncode == 1 and "unknown key 'camera.zoom'" in proc.stderr
    assert not out.exists()


def test_demo_refuses_to_overwrite_and_leaves_the_old_file(tmp_path):
    existing = tmp_path / "keep.lfdemo"
    existing.write_bytes(b"precious")
    proc = run_cli("demo", "--out", str(existing))
    assert proc.returncode == 1 and "already exists" in proc.stderr
    assert existing.read_bytes() == b"precious"


def test_every_subcommand_has_help():
    for sub in (
        ["demo"],
        ["evolve"],
        ["drive"],
        ["benchmark"],
        ["hardware"],
        ["hardware", "check"],
    ):
        proc = run_cli(*sub, "--help")
        assert proc.returncode == 0 and "usage:" in proc.stdout


def test_every_help_text_formats():
    """Every parser and sub-parser, at any depth, renders its --help (a bare '%' in a help
    string breaks argparse's formatting only when that help is shown)."""
    import argparse

    from lfd_track.cli import build_parser

    def walk(parser: argparse.ArgumentParser, path: str) -> list[str]:
        assert "usage:" in parser.format_help(), path
        seen = [path]
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, child in action.choices.items():
                    seen += walk(child, f"{path} {name}")
        return seen

    paths = walk(build_parser(), "lfd-track")
    assert {"lfd-track study", "lfd-track teach", "lfd-track hardware check"} <= set(paths)


# ----------------------------------------------------------------- progress, help, defaults
class _Terminal(io.StringIO):
    """A stderr that says it is a terminal, so progress bars draw."""

    def isatty(self) -> bool:
        return True


def test_drive_prints_each_lap_as_it_ends(controller_file, capsys, monkeypatch):
    from lfd_track.benchmark import runner

    real_run_trial = runner.run_trial
    printed_before_lap = []

    def spy(*args, **kwargs):
        printed_before_lap.append(capsys.readouterr().out)
        return real_run_trial(*args, **kwargs)

    monkeypatch.setattr(runner, "run_trial", spy)
    args = ["--quiet", "drive", str(controller_file), "--track", "training", "--laps", "2"]
    assert main(args) == 0
    rest = capsys.readouterr().out
    assert "corners met in order" in printed_before_lap[0] and "lap 1:" not in printed_before_lap[0]
    assert "lap 1:" in printed_before_lap[1] and "lap 2:" not in printed_before_lap[1]
    assert "lap 2:" in rest and "/2 successful" in rest


def test_drive_shows_per_lap_progress_on_a_terminal_only(controller_file, capsys, monkeypatch):
    args = ["drive", str(controller_file), "--track", "training", "--laps", "2", "--json"]
    assert main(args) == 0
    assert capsys.readouterr().err == ""  # stderr is not a terminal here: no bars
    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    assert main(args) == 0
    shown = terminal.getvalue()
    assert "lap 1/2" in shown and "lap 2/2" in shown and "%" in shown and "step " in shown
    json.loads(capsys.readouterr().out)  # stdout stays pure JSON


def test_demo_count_ends_where_the_work_ends(tmp_path, monkeypatch):
    from lfd_track.dataset import load_demonstration

    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    out = tmp_path / "d.lfdemo"
    assert main(["demo", "--seed", "2", "--out", str(out)]) == 0
    counts = re.findall(r"demonstrating: (\d+) commands", terminal.getvalue())
    assert counts and int(counts[-1]) == load_demonstration(out).metadata["commands"]
    assert "/200" not in terminal.getvalue()


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    found = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            found.update(action.choices)
    return found


def test_help_shows_defaults(capsys):
    import os

    from lfd_track.cli import build_parser

    commands = _subcommands(build_parser())
    drive_help = commands["drive"].format_help()
    for option, default in (("--laps", "1"), ("--seed", "0"), ("--track", "testing")):
        text = drive_help.split(f"\n  {option}", 1)[1].split("\n  -", 1)[0]
        assert f"default: {default}" in " ".join(text.split()), option
    bench_help = " ".join(commands["benchmark"].format_help().split())
    cores = len(os.sched_getaffinity(0))
    assert f"default: the number of cores, here {cores}" in bench_help
    for name in ("demo", "evolve"):
        assert "default: 0" in " ".join(commands[name].format_help().split())


def test_hardware_subcommands_have_descriptions():
    from lfd_track.cli import build_parser

    hardware = _subcommands(_subcommands(build_parser())["hardware"])
    assert set(hardware) == {"sim", "check", "calibrate", "drive", "demo"}
    for name, sub in hardware.items():
        assert sub.description and len(sub.description) > 80, name


def test_benchmark_workers_default_to_the_cores(tmp_path, monkeypatch):
    import os

    from lfd_track.benchmark import runner

    class Stop(Exception):
        pass

    def fake_run_benchmark(config, work, *, workers, progress):
        raise Stop(workers)

    monkeypatch.setattr(runner, "run_benchmark", fake_run_benchmark)
    with pytest.raises(Stop) as stopped:
        main(["--quiet", "benchmark", "--quick", "--out", str(tmp_path / "b")])
    assert stopped.value.args == (len(os.sched_getaffinity(0)),)


def test_bad_video_name_is_one_line(controller_file, tmp_path):
    proc = run_cli("drive", str(controller_file), "--video", str(tmp_path / "drive.avi"))
    assert proc.returncode == 1 and len(proc.stderr.strip().splitlines()) == 1
    assert ".mp4 (H.264) or .webm (VP9)" in proc.stderr
