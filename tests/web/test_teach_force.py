"""``lfd-track teach --force``: an earlier recording is kept until the new one is finished."""

from __future__ import annotations

import signal
from pathlib import Path

from test_teach_cli import teach_and_stop

from lfd_track.dataset import load_demonstration

OLD = b"an earlier recording, not to be lost"


def test_force_without_a_single_case_leaves_the_earlier_recording(tmp_path: Path) -> None:
    out = tmp_path / "tk.lfdemo"
    out.write_bytes(OLD)
    stdout, stderr, returncode = teach_and_stop(["--out", str(out), "--force"], [])
    assert returncode == 0, stderr
    assert out.read_bytes() == OLD
    assert [p.name for p in tmp_path.iterdir()] == ["tk.lfdemo"]  # no temp file left
    assert stderr.count("\n") == 1 and "nothing was recorded" in stderr
    assert f"{out} is unchanged" in stderr
    assert "0 cases" not in stdout  # no summary of a recording that was not kept


def test_force_replaces_the_earlier_recording_once_the_new_one_is_finished(
    tmp_path: Path,
) -> None:
    out = tmp_path / "tk.lfdemo"
    out.write_bytes(OLD)

    def still_the_old_file(url: str, lines: list[str]) -> None:
        assert out.read_bytes() == OLD

    stdout, stderr, returncode = teach_and_stop(
        ["--out", str(out), "--force"], ["forward", "left"], before=still_the_old_file
    )
    assert returncode == 0, stderr
    assert f"{out}: 2 cases" in stdout
    demo = load_demonstration(out)
    assert demo.metadata["complete"] and demo.n_cases == 2
    assert [p.name for p in tmp_path.iterdir()] == ["tk.lfdemo"]


def test_a_crash_keeps_the_earlier_recording_and_the_new_cases(tmp_path: Path) -> None:
    out = tmp_path / "tk.lfdemo"
    out.write_bytes(OLD)
    _, _, returncode = teach_and_stop(["--out", str(out), "--force"], ["right"], signal.SIGKILL)
    assert returncode == -signal.SIGKILL
    assert out.read_bytes() == OLD
    (new,) = (p for p in tmp_path.iterdir() if p != out)
    assert new.name.startswith("tk.in-progress-") and new.suffix == ".lfdemo"
    assert load_demonstration(new).commands.tolist() == [2]
