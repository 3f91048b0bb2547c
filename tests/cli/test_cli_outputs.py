"""What ``drive``, ``demo`` and ``evolve`` write: never over something saved, never over an input."""

from __future__ import annotations

import os
import shutil
import signal
import stat
import subprocess
import sys
from pathlib import Path

import pytest
from lfd_test_support import REPO, TEST_DATA, interrupt_demo_after, no_space_for, one_line

from lfd_track.cli import EXIT_INTERRUPTED, EXIT_TERMINATED, main
from lfd_track.dataset import load_demonstration
from lfd_track.demo import demonstrator
from lfd_track.viz.video import DriveVideo

DATA = TEST_DATA


@pytest.fixture
def controller(tmp_path: Path) -> Path:
    """A saved controller (it leaves the training track within a few steps: a short drive)."""
    path = tmp_path / "c.json"
    shutil.copyfile(DATA / "schema1_controller.json", path)
    return path


def _drive(controller: Path, *more: str) -> int:
    return main(["--quiet", "drive", str(controller), "--track", "training", *more])


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
    err = one_line(capsys.readouterr().err)
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
    from lfd_track.viz import plots

    video, plot = tmp_path / "v.mp4", tmp_path / "laps.png"
    assert _drive(controller, "--video", str(video), "--plot", str(plot)) == 0
    numbers = tmp_path / "laps.csv"
    before = video.read_bytes(), plot.read_bytes(), numbers.read_bytes()
    capsys.readouterr()
    monkeypatch.setattr(plots, stop[0], stop[1])
    assert _drive(controller, "--seed", "1", "--video", str(video), "--plot", str(plot)) == code
    one_line(capsys.readouterr().err)
    assert (video.read_bytes(), plot.read_bytes(), numbers.read_bytes()) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json", "laps.csv", "laps.png", "v.mp4"]


def test_an_interrupted_first_drive_leaves_no_video(controller, tmp_path, monkeypatch, capsys):
    video = tmp_path / "v.webm"
    _stop_video_after(monkeypatch, 2, _ctrl_c)
    assert _drive(controller, "--video", str(video)) == EXIT_INTERRUPTED
    assert "partial video is discarded" in one_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json"]


def test_a_folder_as_video_name_fails_before_driving(controller, tmp_path, monkeypatch, capsys):
    from lfd_track.benchmark import runner

    def run_trial(*args, **kwargs):
        raise AssertionError("drove although the video cannot be written")

    monkeypatch.setattr(runner, "run_trial", run_trial)
    folder = tmp_path / "somedir.mp4"
    folder.mkdir()
    assert _drive(controller, "--video", str(folder)) == 1
    err = one_line(capsys.readouterr().err)
    assert f"lfd-track drive: {folder}: is a folder" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json", "somedir.mp4"]
    assert list(folder.iterdir()) == []


@pytest.mark.parametrize("flag", ["--video", "--plot"])
def test_a_file_below_a_file_fails_before_driving(controller, tmp_path, capsys, flag):
    name = "x.mp4" if flag == "--video" else "x.png"
    assert _drive(controller, flag, str(controller / name)) == 1
    err = one_line(capsys.readouterr().err)
    assert str(controller) in err and "not a folder" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json"]


# --------------------------------------------------------------------------------- inputs as outputs
def test_drive_refuses_to_write_over_its_controller(controller, tmp_path, capsys):
    before = controller.read_bytes()
    assert _drive(controller, "--plot", str(controller)) == 1
    err = one_line(capsys.readouterr().err)
    assert f"{controller}: is the controller" in err
    as_video = tmp_path / "c.mp4"  # a controller file may have any name
    shutil.copyfile(controller, as_video)
    assert _drive(as_video, "--video", str(as_video)) == 1
    assert "is the controller" in one_line(capsys.readouterr().err)
    link = tmp_path / "link.png"
    link.symlink_to(controller)
    assert _drive(controller, "--plot", str(link)) == 1
    assert "is the controller" in one_line(capsys.readouterr().err)
    assert controller.read_bytes() == before and as_video.read_bytes() == before


def test_drive_refuses_the_same_file_for_plot_and_video(controller, tmp_path, capsys):
    out = tmp_path / "out.mp4"
    assert _drive(controller, "--video", str(out), "--plot", str(out)) == 1
    assert "both --video and --plot" in one_line(capsys.readouterr().err)
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
        err = one_line(capsys.readouterr().err)
        assert f"lfd-track evolve: {out}: is the demonstration" in err
    hard = tmp_path / "hard.json"
    os.link(small_demo, hard)
    assert main(["--quiet", "evolve", str(small_demo), "--out", str(hard)]) == 1
    assert "is the demonstration" in one_line(capsys.readouterr().err)
    assert small_demo.read_bytes() == before
    assert not small_demo.with_suffix(".fitness.png").exists()


@pytest.mark.parametrize("failure", ["full disk for the plot", "Ctrl-C while plotting"])
def test_a_failed_evolve_leaves_the_earlier_controller_and_plot(
    small_demo, tmp_path, monkeypatch, capsys, failure
):
    out = tmp_path / "c.json"
    out.write_text("an earlier controller")
    png = tmp_path / "c.fitness.png"
    png.write_bytes(b"its fitness curve")
    if failure.startswith("full disk"):
        monkeypatch.setattr(os, "replace", no_space_for(png))
    else:
        from lfd_track.viz import plots

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
    assert f"kept at {second} " in one_line(capsys.readouterr().err)
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
    err = one_line(capsys.readouterr().err)
    assert f"{parent / 'x.lfdemo'}: {parent} is not a folder" in err and "File exists" not in err
    assert parent.read_bytes() == b"not a folder"


# --------------------------------------------------------------- outputs replace regular files only
def _special(kind: str, path: Path) -> None:
    """Make ``path`` a FIFO, a symbolic link to a regular file, or a dangling symbolic link."""
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "link":
        target = path.with_name("target-" + path.name)
        target.write_bytes(b"the file the link points to")
        path.symlink_to(target)
    else:
        path.symlink_to(path.with_name("nowhere-" + path.name))


def _unchanged(kind: str, path: Path) -> None:
    info = os.lstat(path)
    if kind == "fifo":
        assert stat.S_ISFIFO(info.st_mode)
    else:
        assert stat.S_ISLNK(info.st_mode)
        if kind == "link":
            assert os.readlink(path) == str(path.with_name("target-" + path.name))
            assert path.with_name("target-" + path.name).read_bytes() == (
                b"the file the link points to"
            )


def _output_commands(controller: Path, demo: Path, out: Path) -> dict[str, list[str]]:
    return {
        "evolve --out": ["evolve", str(demo), "--generations", "1", "--out", str(out)],
        "drive --plot": ["drive", str(controller), "--track", "training", "--plot", str(out)],
        "drive --video": ["drive", str(controller), "--track", "training", "--video", str(out)],
        "demo --force --out": ["demo", "--force", "--out", str(out)],
        "demo --out": ["demo", "--out", str(out)],
    }


SUFFIX = {"evolve --out": ".json", "drive --plot": ".png", "drive --video": ".mp4"}


@pytest.mark.parametrize("kind", ["fifo", "link", "dangling link"])
@pytest.mark.parametrize("command", list(_output_commands(Path(), Path(), Path())))
def test_an_output_that_is_not_a_regular_file_is_refused_before_any_work(
    controller, small_demo, tmp_path, monkeypatch, capsys, kind, command
):
    out = tmp_path / ("out" + SUFFIX.get(command, ".lfdemo"))
    _special(kind, out)
    _no_fsync(monkeypatch)
    before = sorted(p.name for p in tmp_path.iterdir())
    code = main(["--quiet", *_output_commands(controller, small_demo, out)[command]])
    err = one_line(capsys.readouterr().err)
    assert code == 1, err
    assert str(out) in err and ("symbolic link" in err or "a FIFO" in err), err
    _unchanged(kind, out)
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written beside it


def test_dev_null_as_an_output_is_refused_and_stays_a_device(controller, small_demo, capsys):
    from lfd_track.errors import LfdTrackError
    from lfd_track.utils.outputs import refuse_unsafe_output

    # First the check itself, so that a version without it never gets to replace the device.
    with pytest.raises(LfdTrackError, match="is a device"):
        refuse_unsafe_output("/dev/null")
    before = os.stat("/dev/null")
    assert stat.S_ISCHR(before.st_mode)
    for command, args in _output_commands(controller, small_demo, Path("/dev/null")).items():
        assert main(["--quiet", *args]) == 1, command
        assert "/dev/null: exists and is a device" in one_line(capsys.readouterr().err)
    after = os.stat("/dev/null")
    assert stat.S_ISCHR(after.st_mode) and after.st_rdev == before.st_rdev
    assert after.st_ino == before.st_ino
    assert not Path("/dev/null.fitness.png").exists()


@pytest.mark.parametrize("kind", ["fifo", "link"])
def test_benchmark_refuses_a_linked_output_folder_or_special_files_in_it(tmp_path, capsys, kind):
    folder = tmp_path / "real"
    folder.mkdir()
    if kind == "link":
        out = tmp_path / "results"
        out.symlink_to(folder)
        shown = out
    else:
        out = folder
        shown = folder / "report.md"
        os.mkfifo(shown)
    code = main(["--quiet", "benchmark", "--quick", "--workers", "1", "--out", str(out)])
    err = one_line(capsys.readouterr().err)
    assert code == 1 and f"{shown}: " in err, err
    assert os.listdir(folder) == ([] if kind == "link" else ["report.md"])
    assert sorted(os.listdir(tmp_path)) == (["real", "results"] if kind == "link" else ["real"])


def test_teach_refuses_a_fifo_before_opening_a_session(tmp_path, monkeypatch, capsys):
    from lfd_track.web import session

    def opened(args):
        raise AssertionError("the session was opened")

    monkeypatch.setattr(session, "open_session", opened)
    out = tmp_path / "t.lfdemo"
    os.mkfifo(out)
    code = main(["--quiet", "teach", "--force", "--port", "0", "--out", str(out)])
    assert code == 1 and "a FIFO" in one_line(capsys.readouterr().err)
    assert stat.S_ISFIFO(os.lstat(out).st_mode)


def test_hardware_demo_refuses_a_link_before_opening_the_robot(tmp_path, monkeypatch, capsys):
    from lfd_track.cli import hardware as hardware_cli

    def opened(*args, **kwargs):
        raise AssertionError("the robot was opened")

    monkeypatch.setattr(hardware_cli, "_make_env", opened)
    out = tmp_path / "h.lfdemo"
    _special("link", out)
    args = ["--quiet", "hardware", "demo", "--camera", "0", "--serial", "loop://", "--out"]
    assert main([*args, str(out)]) == 1
    assert "symbolic link" in one_line(capsys.readouterr().err)
    _unchanged("link", out)


# ------------------------------------------------------------------ names that are not UTF-8
def _run(*args: str | bytes) -> subprocess.CompletedProcess:
    """The command in a child process (a crash in OpenCV is an exit code, not a dead pytest)."""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run(
        [sys.executable, "-m", "lfd_track.cli", "--quiet", *args],
        capture_output=True,
        env=env,
        timeout=600,
    )


def _bad(folder: Path, name: bytes) -> bytes:
    """A path in ``folder`` whose last part is ``name`` (bytes that are not UTF-8)."""
    return os.fsencode(folder) + b"/" + name


def test_evolve_from_a_demonstration_named_with_a_byte_that_is_not_utf8(small_demo, tmp_path):
    demo = _bad(tmp_path, b"x\xff.lfdemo")
    shutil.copyfile(small_demo, demo)
    out = tmp_path / "c.json"
    proc = _run("evolve", demo, "--generations", "1", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert out.exists() and tmp_path.joinpath("c.fitness.png").exists()
    proc.stdout.decode("utf-8")  # what it prints is UTF-8 too


def test_drive_with_names_that_are_not_utf8(controller, tmp_path):
    bad_controller = _bad(tmp_path, b"c\xff.json")
    shutil.copyfile(controller, bad_controller)
    track = _bad(tmp_path, b"l\xff.toml")
    shutil.copyfile(REPO / "tracks" / "training.toml", track)
    plot = _bad(tmp_path, b"p\xff.png")
    proc = _run("drive", bad_controller, "--track", track, "--plot", plot)
    assert proc.returncode == 0, proc.stderr
    assert os.path.getsize(plot) > 0
    assert "l\\xff.toml" in proc.stdout.decode("utf-8")
    proc = _run("drive", str(controller), "--track", track, "--json")
    assert proc.returncode == 0, proc.stderr
    import json

    assert json.loads(proc.stdout.decode("utf-8"))["track"].endswith("l\\xff.toml")


@pytest.mark.parametrize("command", ["benchmark", "demo"])
def test_a_track_named_with_a_byte_that_is_not_utf8_is_refused_before_the_run(tmp_path, command):
    track = _bad(tmp_path, b"l\xff.toml")
    shutil.copyfile(REPO / "tracks" / "testing.toml", track)
    out = tmp_path / "out"
    if command == "benchmark":
        args = ["benchmark", "--quick", "--workers", "1", "--test-track", track]
    else:
        args = ["demo", "--track", track]
    proc = _run(*args, "--out", str(out))
    err = proc.stderr.decode("utf-8")
    assert proc.returncode == 1 and err.count("\n") == 1, err
    assert "l\\xff.toml: the " in err and "not valid UTF-8" in err
    assert not out.exists()
