"""``lfd-track demo``/``evolve`` with interrupted recordings: nothing lost, nothing unusable."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

import pytest
from lfd_test_support import interrupt_demo_after

from lfd_track.cli import EXIT_INTERRUPTED, EXIT_TERMINATED, main
from lfd_track.dataset import load_demonstration


def _interrupt_after(monkeypatch, commands: int, signum: int = signal.SIGTERM) -> None:
    """Make the next ``demo`` receive ``signum`` (a real signal) after ``commands`` commands."""
    interrupt_demo_after(monkeypatch, commands, signum)


@pytest.fixture(scope="module")
def partial_recording(tmp_path_factory):
    """A demo stopped by SIGTERM after 70 commands, and what the command printed."""
    work = tmp_path_factory.mktemp("partial")
    out = work / "demo.lfdemo"
    with pytest.MonkeyPatch.context() as mp:
        _interrupt_after(mp, 70)
        import contextlib
        import io

        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            code = main(["--quiet", "demo", "--seed", "2", "--out", str(out)])
    return out, code, err.getvalue()


def test_sigterm_keeps_a_visible_partial_recording_and_says_where(partial_recording):
    out, code, err = partial_recording
    assert code == EXIT_TERMINATED
    assert f"kept at {out}" in err and "interrupted after 70 commands" in err
    assert [p.name for p in out.parent.iterdir()] == ["demo.lfdemo"]  # nothing hidden beside it
    demo = load_demonstration(out)
    assert demo.metadata["complete"] is False
    assert demo.n_cases == 60  # the first 10 commands only build the library
    assert f"({demo.n_cases} cases)" in err
    assert demo.metadata["road_library"]["types"]  # replayed from the library log


def test_evolve_trains_on_an_interrupted_recording(partial_recording, tmp_path, capsys):
    out, _, _ = partial_recording
    controller = tmp_path / "c.json"
    code = main(["--quiet", "evolve", str(out), "--generations", "3", "--out", str(controller)])
    assert code == 0
    assert "an interrupted recording" in capsys.readouterr().out
    data = json.loads(controller.read_text())
    assert data["road_library"] == load_demonstration(out).metadata["road_library"]


def test_an_earlier_recording_is_never_replaced_without_force(
    partial_recording, tmp_path, monkeypatch, capsys
):
    out, _, _ = partial_recording
    before = out.read_bytes()
    assert main(["--quiet", "demo", "--seed", "3", "--out", str(out)]) == 1
    assert "already exists" in capsys.readouterr().err
    assert out.read_bytes() == before

    # --force records beside the old file; interrupted, the old one is still whole.
    copy = tmp_path / "demo.lfdemo"
    copy.write_bytes(before)
    _interrupt_after(monkeypatch, 20, signal.SIGINT)
    code = main(["--quiet", "demo", "--seed", "3", "--force", "--out", str(copy)])
    assert code == EXIT_INTERRUPTED
    partial = tmp_path / "demo.partial.lfdemo"
    assert f"kept at {partial}" in capsys.readouterr().err
    assert copy.read_bytes() == before and load_demonstration(partial).n_cases == 10


def test_force_replaces_once_the_new_recording_is_complete(tmp_path, capsys):
    out = tmp_path / "d.lfdemo"
    out.write_bytes(b"an older recording")
    assert main(["--quiet", "demo", "--seed", "1", "--force", "--out", str(out)]) == 0
    assert load_demonstration(out).metadata["complete"] is True
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.lfdemo"]
    assert "d.lfdemo: " in capsys.readouterr().out


def test_output_names_that_are_not_utf8_work(partial_recording, tmp_path, capsys):
    out, _, _ = partial_recording
    name = os.fsdecode(b"ctrl-\xff\xfe.json")
    controller = tmp_path / name
    code = main(["--quiet", "evolve", str(out), "--generations", "2", "--out", str(controller)])
    assert code == 0
    assert os.fsencode(controller) in [os.fsencode(p) for p in tmp_path.iterdir()]
    printed = capsys.readouterr().out
    assert "ctrl-\\xff\\xfe.json" in printed
    demo_name = tmp_path / os.fsdecode(b"demo-\xff.lfdemo")
    demo_name.write_bytes(Path(out).read_bytes())
    assert main(["--quiet", "demo", "--out", str(demo_name)]) == 1
    assert "demo-\\xff.lfdemo: already exists" in capsys.readouterr().err


_VIDEO = """
import os, sys
import numpy as np
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.viz.video import DriveVideo

env = LfDTrackEnv(track="training")
frame, info = env.reset(seed=0)
video = DriveVideo(os.path.join(sys.argv[1], os.fsdecode(b"v-\\xff.mp4")), env)
for _ in range(3):
    video.add(frame, np.zeros(40), info)
    frame, _, _, _, info = env.step(0)
video.close()
"""


def test_video_with_a_name_that_is_not_utf8(tmp_path):
    import subprocess
    import sys

    # In a child: OpenCV used to crash the process (SIGSEGV) on such a name.
    proc = subprocess.run(
        [sys.executable, "-c", _VIDEO, str(tmp_path)], capture_output=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert [os.fsencode(p.name) for p in tmp_path.iterdir()] == [b"v-\xff.mp4"]
    assert (tmp_path / os.fsdecode(b"v-\xff.mp4")).stat().st_size > 1000
