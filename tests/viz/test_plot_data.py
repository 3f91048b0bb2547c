"""Every PNG a command writes has its numbers beside it: a CSV of the same stem, whose rows are
the very numbers the picture was drawn from (read back, they equal the run's own)."""

from __future__ import annotations

import json
import os
import re
import shutil
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
from lfd_test_support import REPO, TEST_DATA, no_space_for, one_line
from study.study_helpers import job_results, write_study

from lfd_track.cli import EXIT_INTERRUPTED, main
from lfd_track.viz.plot_data import data_path, read_table

DATA = TEST_DATA


def _pictures_have_numbers(folder: Path) -> list[Path]:
    """Every PNG under ``folder`` has a CSV of the same stem with a header row; returns them."""
    pictures = sorted(folder.rglob("*.png"))
    assert pictures
    for png in pictures:
        numbers = data_path(png)
        assert numbers.is_file(), f"{png.name} has no {numbers.name}"
        assert numbers.read_text(encoding="utf-8").splitlines()[0].count(",") >= 2
    return pictures


def _paths(rows: list[dict[str, str]], key: tuple[str, ...]) -> dict[tuple, np.ndarray]:
    """The (x, y) points of each run, by the values of the ``key`` columns, in point order."""
    points: dict[tuple, list[tuple[int, float, float]]] = defaultdict(list)
    for row in rows:
        points[tuple(row[k] for k in key)].append(
            (int(row["point"]), float(row["x_m"]), float(row["y_m"]))
        )
    out = {}
    for run, pts in points.items():
        assert [p[0] for p in pts] == list(range(len(pts)))
        out[run] = np.array([p[1:] for p in pts])
    return out


def test_no_module_writes_a_png_without_its_numbers():
    """Only the picture writer of plot_data calls write_png: every other picture goes through
    write_picture (or stage_picture), which writes the numbers beside it."""
    callers = []
    for path in sorted((REPO / "lfd_track").rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        if re.search(r"\bwrite_png\(|\bimwrite\(", text):
            callers.append(str(path.relative_to(REPO)))
    assert callers == ["lfd_track/viz/plot_data.py", "lfd_track/viz/plots.py"]


# --------------------------------------------------------------------------------- evolve
@pytest.fixture(scope="module")
def demo(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("demo") / "d.lfdemo"
    assert main(["--quiet", "demo", "--seed", "1", "--out", str(out)]) == 0
    return out


def test_evolve_writes_the_fitness_curves_numbers(demo, tmp_path, monkeypatch, capsys):
    from lfd_track.cli import evolve as evolve_cli

    results = []
    real = evolve_cli.evolve

    def evolve(*args, **kwargs):
        results.append(real(*args, **kwargs))
        return results[-1]

    monkeypatch.setattr(evolve_cli, "evolve", evolve)
    out = tmp_path / "c.json"
    assert main(["--quiet", "evolve", str(demo), "--generations", "6", "--out", str(out)]) == 0
    assert "c.fitness.csv" in capsys.readouterr().out
    (png,) = _pictures_have_numbers(tmp_path)
    assert png.name == "c.fitness.png"
    rows = read_table(tmp_path / "c.fitness.csv")
    assert list(rows[0]) == ["curve", "generation", "fitness"]
    (result,) = results
    for curve, history in (("best", result.best_history), ("mean", result.mean_history)):
        mine = [r for r in rows if r["curve"] == curve]
        assert [int(r["generation"]) for r in mine] == list(range(1, 7))
        assert [float(r["fitness"]) for r in mine] == [float(v) for v in history]
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "c.fitness.csv",
        "c.fitness.png",
        "c.json",
    ]


@pytest.mark.parametrize("failing", ["c.fitness.png", "c.json"])
def test_a_failed_evolve_leaves_the_earlier_three_files(
    demo, tmp_path, monkeypatch, capsys, failing
):
    """The numbers are moved in first: when a later file cannot be, they are put back."""
    before = {
        "c.json": b"an earlier controller",
        "c.fitness.png": b"its fitness curve",
        "c.fitness.csv": b"its numbers",
    }
    for name, data in before.items():
        (tmp_path / name).write_bytes(data)
    monkeypatch.setattr(os, "replace", no_space_for(tmp_path / failing))
    args = ["--quiet", "evolve", str(demo), "--generations", "2", "--out", str(tmp_path / "c.json")]
    assert main(args) == 1
    assert "No space left" in one_line(capsys.readouterr().err)
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_evolve_refuses_a_link_where_the_numbers_go_before_any_work(demo, tmp_path, capsys):
    target = tmp_path / "elsewhere.csv"
    target.write_text("someone's table")
    link = tmp_path / "c.fitness.csv"
    link.symlink_to(target)
    args = ["--quiet", "evolve", str(demo), "--generations", "2", "--out", str(tmp_path / "c.json")]
    assert main(args) == 1
    err = one_line(capsys.readouterr().err)
    assert f"{link}: is a symbolic link" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.fitness.csv", "elsewhere.csv"]
    assert target.read_text() == "someone's table"


# --------------------------------------------------------------------------------- drive
@pytest.fixture
def controller(tmp_path: Path) -> Path:
    path = tmp_path / "c.json"
    shutil.copyfile(DATA / "schema1_controller.json", path)
    return path


def test_drive_plot_writes_each_laps_path(controller, tmp_path, monkeypatch, capsys):
    from lfd_track.benchmark import runner

    paths = []
    real = runner.run_trial

    def run_trial(*args, **kwargs):
        info, trajectory, steps = real(*args, **kwargs)
        paths.append(trajectory.copy())
        return info, trajectory, steps

    monkeypatch.setattr(runner, "run_trial", run_trial)
    plot = tmp_path / "laps.png"
    args = ["drive", str(controller), "--track", "training", "--laps", "3", "--plot", str(plot)]
    assert main(["--quiet", *args, "--json"]) == 0
    laps = json.loads(capsys.readouterr().out)["laps"]
    _pictures_have_numbers(tmp_path)
    rows = read_table(tmp_path / "laps.csv")
    assert list(rows[0]) == ["lap", "outcome", "point", "x_m", "y_m"]
    drawn = _paths(rows, ("lap",))
    assert sorted(drawn) == [("1",), ("2",), ("3",)]
    for lap, path in zip(laps, paths, strict=True):
        np.testing.assert_array_equal(drawn[(str(lap["lap"]),)], path[:, :2])
        outcome = "success" if lap["success"] else lap["failure"]
        assert {r["outcome"] for r in rows if r["lap"] == str(lap["lap"])} == {outcome}


def test_drive_refuses_a_fifo_where_the_plots_numbers_go(controller, tmp_path, capsys):
    fifo = tmp_path / "laps.csv"
    os.mkfifo(fifo)
    args = ["--quiet", "drive", str(controller), "--track", "training"]
    assert main([*args, "--plot", str(tmp_path / "laps.png")]) == 1
    assert f"{fifo}: exists and is a FIFO" in one_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json", "laps.csv"]


@pytest.mark.parametrize("flags", [["--plot", "x.csv"], ["--plot", "x.png", "--video", "x.csv"]])
def test_drive_refuses_a_plot_whose_numbers_would_overwrite_an_output(
    controller, tmp_path, capsys, flags
):
    args = ["--quiet", "drive", str(controller), "--track", "training"]
    assert main([*args, *[str(tmp_path / f) if "." in f else f for f in flags]]) == 1
    err = one_line(capsys.readouterr().err)
    assert "x.csv" in err and ("suffix .csv" in err or "--plot's numbers" in err), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json"]


def test_a_drive_interrupted_at_its_plot_writes_no_numbers(
    controller, tmp_path, monkeypatch, capsys
):
    from lfd_track.viz import plots

    def ctrl_c(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(plots, "write_png", ctrl_c)  # the numbers are staged before the picture
    args = ["--quiet", "drive", str(controller), "--track", "training"]
    assert main([*args, "--plot", str(tmp_path / "laps.png")]) == EXIT_INTERRUPTED
    capsys.readouterr()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json"]


# --------------------------------------------------------------------------------- benchmark
@pytest.mark.slow
def test_the_benchmark_writes_the_numbers_of_both_pictures(tmp_path, monkeypatch):
    from lfd_track.benchmark import report

    captured = []
    real = report.write_benchmark_outputs

    def write(out, config, reps, **kwargs):
        captured.append(reps)
        return real(out, config, reps, **kwargs)

    monkeypatch.setattr(report, "write_benchmark_outputs", write)
    out = tmp_path / "bench"
    args = ["--quiet", "benchmark", "--quick", "--workers", "1", "--seed", "2"]
    assert main([*args, "--out", str(out)]) == 0
    top = sorted(p.name for p in _pictures_have_numbers(out))
    assert top == ["fitness.png", "trajectories.png"]
    (reps,) = captured

    rows = read_table(out / "fitness.csv")
    assert list(rows[0]) == ["curve", "generation", "fitness"]
    (rep,) = reps
    assert [float(r["fitness"]) for r in rows] == [float(v) for v in rep.fitness_best]
    assert {r["curve"] for r in rows} == {f"rep {rep.index}"}

    rows = read_table(out / "trajectories.csv")
    key = ("track", "direction", "repetition", "trial")
    assert list(rows[0]) == [*key, "outcome", "point", "x_m", "y_m"]
    drawn = _paths(rows, key)
    assert len(drawn) == len(rep.outcomes) == 4
    for o in rep.outcomes:
        run = (o.track, o.direction, str(o.repetition), str(o.trial))
        np.testing.assert_array_equal(drawn[run], o.trajectory[:, :2])
        outcome = "success" if o.success else o.failure
        assert {r["outcome"] for r in rows if tuple(r[k] for k in key) == run} == {outcome}


def test_the_benchmark_refuses_a_fifo_where_a_pictures_numbers_go(tmp_path, capsys):
    out = tmp_path / "bench"
    out.mkdir()
    os.mkfifo(out / "trajectories.csv")
    args = ["--quiet", "benchmark", "--quick", "--workers", "1", "--out", str(out)]
    assert main(args) == 1
    assert f"{out / 'trajectories.csv'}: exists and is a FIFO" in one_line(capsys.readouterr().err)
    assert os.listdir(out) == ["trajectories.csv"]


def test_the_trajectories_picture_leaves_out_the_extra_loops_runs():
    """An extra loop's runs are named ccw/cw like the testing track's; they were drawn on the
    testing track's panels (in another track's coordinates) and counted in their headings."""
    from lfd_track.benchmark.report import trajectories_picture
    from lfd_track.benchmark.runner import BenchmarkConfig
    from lfd_track.benchmark.tables import TrialOutcome

    def run(track, direction, order, shift):
        path = np.column_stack([np.linspace(0, 1, 20) + shift, np.full(20, 0.5), np.zeros(20)])
        return TrialOutcome(
            track=track,
            direction=direction,
            corner_order=order,
            corners_reached=(),
            corners_negotiated=(),
            failure="off_track",
            success=False,
            repetition=0,
            trial=0,
            steps=20,
            trajectory=path,
        )

    config = BenchmarkConfig(
        repetitions=1, trials_per_direction=1, test_tracks=("testing", "notch")
    )
    paper = [
        run("training", "direction_1", ("1", "2"), 0.0),
        run("training", "direction_2", ("1", "2"), 0.0),
        run("testing", "ccw", ("4", "1", "2", "3"), 0.0),
        run("testing", "cw", ("4", "3", "2", "1"), 0.0),
    ]
    extra = [run("notch", "ccw", ("1",), 0.7), run("notch", "cw", ("1",), 0.7)]
    np.testing.assert_array_equal(
        trajectories_picture(config, paper + extra), trajectories_picture(config, paper)
    )


# --------------------------------------------------------------------------------- study
def _stored_study(tmp_path: Path):
    from lfd_track.study.jobs import RESULTS_FILE
    from lfd_track.study.spec import load_study

    path = write_study(tmp_path)
    study = load_study(path)
    out = tmp_path / "out"
    for job in study.jobs():
        results = out / job.key / RESULTS_FILE
        results.parent.mkdir(parents=True)
        results.write_text(json.dumps(job_results(job)))
    return path, out


def test_the_study_writes_the_numbers_of_its_success_rates(tmp_path, monkeypatch, capsys):
    from lfd_track.study import run as run_module

    def no_job(job):
        raise AssertionError(f"job {job.key} ran although its results are stored")

    monkeypatch.setattr(run_module, "run_job", no_job)
    path, out = _stored_study(tmp_path)
    assert main(["--quiet", "study", str(path), "--out", str(out)]) == 0
    capsys.readouterr()
    assert [p.name for p in _pictures_have_numbers(out)] == ["study.png"]
    summary = json.loads((out / "study.json").read_text())
    rows = read_table(out / "study.csv")
    assert list(rows[0]) == [
        "condition",
        "method",
        "preset",
        "series",
        "successes",
        "trials",
        "rate",
        "ci95_low",
        "ci95_high",
    ]
    expected = [
        (c["name"], c["method"], c["preset"], series, c[series])
        for c in summary["conditions"]
        for series in ("training", "testing", "unseen")
        if c[series]["trials"]
    ]
    expected.append(("paper", "paper", "", "testing", summary["paper"]["testing"]))
    assert len(rows) == len(expected) == 3
    for row, (name, method, preset, series, r) in zip(rows, expected, strict=True):
        assert (row["condition"], row["method"], row["preset"], row["series"]) == (
            name,
            method,
            preset,
            series,
        )
        assert (int(row["successes"]), int(row["trials"])) == (r["successes"], r["trials"])
        assert float(row["rate"]) == pytest.approx(r["rate"], abs=1e-6)
        assert [float(row["ci95_low"]), float(row["ci95_high"])] == pytest.approx(
            r["ci95"], abs=1e-6
        )


def test_the_study_refuses_a_link_where_its_plots_numbers_go(tmp_path, capsys):
    path, out = _stored_study(tmp_path)
    (out / "study.csv").symlink_to(tmp_path / "nowhere.csv")
    assert main(["--quiet", "study", str(path), "--out", str(out)]) == 1
    assert "study.csv: is a symbolic link" in one_line(capsys.readouterr().err)
    assert not (out / "study.png").exists() and not (tmp_path / "nowhere.csv").exists()
