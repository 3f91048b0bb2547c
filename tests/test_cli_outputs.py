"""What ``drive``, ``demo`` and ``evolve`` write: never over something saved, never over an input."""

from __future__ import annotations

import os
import shutil
import signal
from pathlib import Path

import pytest
from lfd_test_support import interrupt_demo_after

from lfd_track.cli import EXIT_INTERRUPTED, EXIT_TERMINATED, main
from lfd_track.demo import demonstrator
from lfd_track.demo.dataset import load_demonstration
from lfd_track.video import DriveVideo

DATA = Path(__file__).parent / "data"


@pytest.fixture
def controller(tmp_path: Path) -> Path:
    """A saved controller (it leaves the training track within a few steps: a short drive)."""
    path = tmp_path / "c.json"
    shutil.copyfile(DATA / "schema1_controller.json", path)
    return path


def _drive(controller: Path, *more: str) -> int:
    return main(["--quiet", "drive", str(controller), "--track", "training", *more])


def _one_line(err: str) -> str:
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


# --------------------------------------------------------------------------------- drive --video
def _stop_video_after(monkeypatch, frames: int, stop) -> None:
    """The drive is stopped (``stop()``) once its video holds ``frames`` frames."""
    real_add = DriveVideo.add
    added = 0

    def add(self, *args, **kwargs):
        nonlocal added
        real_add(self, *args, **kwargs)
        added += 1
        if added == frames:
            stop()

    monkeypatch.setattr(DriveVideo, "add", add)


def _ctrl_c() -> None:
    raise KeyboardInterrupt


def _sigterm() -> None:
    os.kill(os.getpid(), signal.SIGTERM)


def _ctrl_c_while_plotting(*args, **kwargs):
    raise KeyboardInterrupt


@pytest.mark.parametrize(
    ("stop", "code"), [(_ctrl_c, EXIT_INTERRUPTED), (_sigterm, EXIT_TERMINATED)]
)
def test_an_interrupted_drive_leaves_the_earlier_video_alone(
    controller, tmp_path, monkeypatch, capsys, stop, code
):
    video = tmp_path / "v.mp4"
    assert _drive(controller, "--video", str(video)) == 0
    before = video.read_bytes()
    capsys.readouterr()
    _stop_video_after(monkeypatch, 3, stop)
    assert _drive(controller, "--laps", "500", "--video", str(video)) == code
    assert video.read_bytes() == before
    err = _one_line(capsys.readouterr().err)
    assert "partial video is discarded" in err and str(video) in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json", "v.mp4"]  # no temp file


def _disk_full(*args, **kwargs):
    raise OSError(28, "No space left on device")


@pytest.mark.parametrize(
    ("stop", "code"),
    [(("laps_plot", _ctrl_c_while_plotting), EXIT_INTERRUPTED), (("write_png", _disk_full), 1)],
    ids=["Ctrl-C while drawing the plot", "full disk for the plot"],
)
def test_a_drive_stopped_at_its_plot_leaves_the_earlier_video_and_plot(
    controller, tmp_path, monkeypatch, capsys, stop, code
):
    from lfd_track import plots

    video, plot = tmp_path / "v.mp4", tmp_path / "laps.png"
    assert _drive(controller, "--video", str(video), "--plot", str(plot)) == 0
    before = video.read_bytes(), plot.read_bytes()
    capsys.readouterr()
    monkeypatch.setattr(plots, stop[0], stop[1])
    assert _drive(controller, "--seed", "1", "--video", str(video), "--plot", str(plot)) == code
    _one_line(capsys.readouterr().err)
    assert (video.read_bytes(), plot.read_bytes()) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json", "laps.png", "v.mp4"]


def test_an_interrupted_first_drive_leaves_no_video(controller, tmp_path, monkeypatch, capsys):
    video = tmp_path / "v.webm"
    _stop_video_after(monkeypatch, 2, _ctrl_c)
    assert _drive(controller, "--video", str(video)) == EXIT_INTERRUPTED
    assert "partial video is discarded" in _one_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json"]


def test_a_folder_as_video_name_fails_before_driving(controller, tmp_path, monkeypatch, capsys):
    from lfd_track.benchmark import runner

    def run_trial(*args, **kwargs):
        raise AssertionError("drove although the video cannot be written")

    monkeypatch.setattr(runner, "run_trial", run_trial)
    folder = tmp_path / "somedir.mp4"
    folder.mkdir()
    assert _drive(controller, "--video", str(folder)) == 1
    err = _one_line(capsys.readouterr().err)
    assert f"lfd-track drive: {folder}: is a folder" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json", "somedir.mp4"]
    assert list(folder.iterdir()) == []


@pytest.mark.parametrize("flag", ["--video", "--plot"])
def test_a_file_below_a_file_fails_before_driving(controller, tmp_path, capsys, flag):
    name = "x.mp4" if flag == "--video" else "x.png"
    assert _drive(controller, flag, str(controller / name)) == 1
    err = _one_line(capsys.readouterr().err)
    assert str(controller) in err and "not a folder" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json"]


# --------------------------------------------------------------------------------- inputs as outputs
def test_drive_refuses_to_write_over_its_controller(controller, tmp_path, capsys):
    before = controller.read_bytes()
    assert _drive(controller, "--plot", str(controller)) == 1
    err = _one_line(capsys.readouterr().err)
    assert f"{controller}: is the controller" in err
    as_video = tmp_path / "c.mp4"  # a controller file may have any name
    shutil.copyfile(controller, as_video)
    assert _drive(as_video, "--video", str(as_video)) == 1
    assert "is the controller" in _one_line(capsys.readouterr().err)
    link = tmp_path / "link.png"
    link.symlink_to(controller)
    assert _drive(controller, "--plot", str(link)) == 1
    assert "is the controller" in _one_line(capsys.readouterr().err)
    assert controller.read_bytes() == before and as_video.read_bytes() == before


def test_drive_refuses_the_same_file_for_plot_and_video(controller, tmp_path, capsys):
    out = tmp_path / "out.mp4"
    assert _drive(controller, "--video", str(out), "--plot", str(out)) == 1
    assert "both --video and --plot" in _one_line(capsys.readouterr().err)
    assert not out.exists()


@pytest.fixture(scope="module")
def small_demo(tmp_path_factory) -> Path:
    """A demonstration cut short by Ctrl-C after 20 commands (10 cases)."""
    out = tmp_path_factory.mktemp("demo") / "self.lfdemo"
    with pytest.MonkeyPatch.context() as mp:
        _interrupt_demo(mp, 20)
        assert main(["--quiet", "demo", "--out", str(out)]) == EXIT_INTERRUPTED
    assert load_demonstration(out).n_cases == 10
    return out


def test_evolve_refuses_to_write_over_its_demonstration(small_demo, tmp_path, capsys):
    before = small_demo.read_bytes()
    for out in (small_demo, small_demo.parent / ".." / small_demo.parent.name / small_demo.name):
        assert main(["--quiet", "evolve", str(small_demo), "--out", str(out)]) == 1
        err = _one_line(capsys.readouterr().err)
        assert f"lfd-track evolve: {out}: is the demonstration" in err
    hard = tmp_path / "hard.json"
    os.link(small_demo, hard)
    assert main(["--quiet", "evolve", str(small_demo), "--out", str(hard)]) == 1
    assert "is the demonstration" in _one_line(capsys.readouterr().err)
    assert small_demo.read_bytes() == before
    assert not small_demo.with_suffix(".fitness.png").exists()


def _no_space_for(path: Path):
    """An ``os.replace`` that fails with a full disk when moving a file to ``path``."""
    real = os.replace

    def replace(src, dst):
        if Path(dst) == path:
            raise OSError(28, "No space left on device", str(dst))
        return real(src, dst)

    return replace


@pytest.mark.parametrize("failure", ["full disk for the plot", "Ctrl-C while plotting"])
def test_a_failed_evolve_leaves_the_earlier_controller_and_plot(
    small_demo, tmp_path, monkeypatch, capsys, failure
):
    out = tmp_path / "c.json"
    out.write_text("an earlier controller")
    png = tmp_path / "c.fitness.png"
    png.write_bytes(b"its fitness curve")
    if failure.startswith("full disk"):
        monkeypatch.setattr(os, "replace", _no_space_for(png))
    else:
        from lfd_track import plots

        monkeypatch.setattr(plots, "fitness_plot", _ctrl_c_while_plotting)
    code = main(["--quiet", "evolve", str(small_demo), "--generations", "2", "--out", str(out)])
    assert code == (1 if failure.startswith("full disk") else EXIT_INTERRUPTED)
    assert out.read_text() == "an earlier controller"
    assert png.read_bytes() == b"its fitness curve"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.fitness.png", "c.json"]


# --------------------------------------------------------------------------------- demo --force
def _interrupt_demo(monkeypatch, commands: int) -> None:
    """The next ``demo`` gets Ctrl-C after ``commands`` commands (and skips fsync: fast)."""
    interrupt_demo_after(monkeypatch, commands, signal.SIGINT, fsync=False)


def _no_fsync(monkeypatch) -> None:
    real = demonstrator.run_demonstration
    monkeypatch.setattr(
        demonstrator,
        "run_demonstration",
        lambda *args, **kwargs: real(*args, **{**kwargs, "fsync": False}),
    )


def test_demo_force_never_touches_a_kept_partial_recording(tmp_path, monkeypatch, capsys):
    out = tmp_path / "x.lfdemo"
    out.write_bytes(b"an older recording")
    kept = tmp_path / "x.partial.lfdemo"
    kept.write_bytes(b"a partial recording an earlier demo kept")

    # Interrupted: the new partial recording goes to a free name, which is printed.
    with monkeypatch.context() as mp:
        _interrupt_demo(mp, 20)
        code = main(["--quiet", "demo", "--force", "--out", str(out)])
    assert code == EXIT_INTERRUPTED
    second = tmp_path / "x.partial-2.lfdemo"
    assert f"kept at {second} " in _one_line(capsys.readouterr().err)
    assert load_demonstration(second).n_cases == 10
    assert kept.read_bytes() == b"a partial recording an earlier demo kept"
    assert out.read_bytes() == b"an older recording"

    # Completed: it replaces the old file, and both partial recordings are still there.
    _no_fsync(monkeypatch)
    assert main(["--quiet", "demo", "--force", "--seed", "1", "--out", str(out)]) == 0
    assert load_demonstration(out).metadata["complete"] is True
    assert kept.read_bytes() == b"a partial recording an earlier demo kept"
    assert load_demonstration(second).n_cases == 10
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "x.lfdemo",
        "x.partial-2.lfdemo",
        "x.partial.lfdemo",
    ]


def test_demo_below_a_file_says_the_parent_is_not_a_folder(tmp_path, capsys):
    parent = tmp_path / "existingfile"
    parent.write_bytes(b"not a folder")
    assert main(["--quiet", "demo", "--out", str(parent / "x.lfdemo")]) == 1
    err = _one_line(capsys.readouterr().err)
    assert f"{parent / 'x.lfdemo'}: {parent} is not a folder" in err and "File exists" not in err
    assert parent.read_bytes() == b"not a folder"
