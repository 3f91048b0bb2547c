"""Drive videos: a codec browsers play (checked in Chromium when it is installed), lap and command
labels, and a trajectory that starts afresh with each lap."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import cv2
import numpy as np
import pytest
from lfd_test_support import unavailable

from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.render.topdown import TRAJECTORY_RGB
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.viz.video import DriveVideo

CHROMIUM = "/usr/bin/chromium"


def _drive(video: DriveVideo, env: LfDTrackEnv, laps: int = 2, steps: int = 12) -> list:
    """Feed ``laps`` short forward drives into ``video``; returns the composed frames per lap."""
    library = RoadLibrary()
    composed = []
    for lap in range(1, laps + 1):
        frame, info = env.reset(seed=lap)
        library.learn(frame)
        lap_frames = []
        for _ in range(steps):
            values = library.road_values(frame)
            lap_frames.append(video.compose(frame, values, info, lap=lap, command=0))
            video.add(frame, values, info, lap=lap, command=0)
            frame, _, terminated, truncated, info = env.step(0)
            if terminated or truncated:
                break
        composed.append(lap_frames)
    video.close()
    return composed


@pytest.fixture(scope="module")
def videos(tmp_path_factory):
    folder = tmp_path_factory.mktemp("videos")
    env = LfDTrackEnv(track="training")
    made = {}
    for suffix in (".mp4", ".webm"):
        path = folder / f"drive{suffix}"
        made[suffix] = (path, _drive(DriveVideo(path, env), env))
    return made


def test_mp4_is_h264_and_webm_is_vp9(videos):
    mp4 = videos[".mp4"][0].read_bytes()
    assert b"ftyp" in mp4[:16] and b"avc1" in mp4 and b"mp4v" not in mp4
    assert mp4.index(b"moov") < mp4.index(b"mdat")  # index first: plays while downloading
    webm = videos[".webm"][0].read_bytes()
    assert webm[:4] == bytes.fromhex("1a45dfa3") and b"V_VP9" in webm
    for path, laps in videos.values():
        cap = cv2.VideoCapture(str(path))
        assert cap.get(cv2.CAP_PROP_FRAME_COUNT) == sum(len(lap) for lap in laps)
        ok, frame = cap.read()
        assert ok and frame.shape[0] == 480
        cap.release()


def _trajectory_pixels(canvas: np.ndarray) -> int:
    top_down = canvas[:, 640:].astype(int)
    return int((np.abs(top_down - np.array(TRAJECTORY_RGB)).sum(axis=2) < 30).sum())


def test_trajectory_starts_afresh_each_lap(videos):
    lap1, lap2 = videos[".mp4"][1]
    assert _trajectory_pixels(lap1[-1]) > 4 * max(_trajectory_pixels(lap1[0]), 10)
    # The first frame of lap 2 shows no trace of lap 1's path.
    assert _trajectory_pixels(lap2[0]) == _trajectory_pixels(lap1[0])


def test_frames_are_labelled_with_lap_and_command(tmp_path):
    env = LfDTrackEnv(track="training")
    frame, info = env.reset(seed=0)
    values = np.zeros(40)
    video = DriveVideo(tmp_path / "v.mp4", env)
    label_box = (slice(0, 40), slice(640, 1040))  # top left of the top-down half
    forward = video.compose(frame, values, info, lap=1, command=0)[label_box]
    left = video.compose(frame, values, info, lap=1, command=1)[label_box]
    lap2 = video.compose(frame, values, info, lap=2, command=0)[label_box]
    assert (forward == 255).all(axis=2).sum() > 300  # white caption text
    assert not np.array_equal(forward, left) and not np.array_equal(forward, lap2)


def test_other_video_names_are_refused(tmp_path):
    with pytest.raises(ValueError, match=r"\.mp4 \(H\.264\) or \.webm"):
        DriveVideo(tmp_path / "drive.avi", env=None)


PAGE = """<!doctype html><meta charset="utf-8"><video id="v" muted playsinline></video>
<pre id="out">pending</pre><script>
const v = document.getElementById("v"), out = document.getElementById("out");
v.addEventListener("error", () => { out.textContent = "error " + (v.error && v.error.code); });
const done = () => {
  out.textContent = "ended " + v.videoWidth + "x" + v.videoHeight + " " + v.duration.toFixed(1);
};
v.addEventListener("ended", done);
// Headless Chromium does not always fire "ended"; reaching the last frame's time is the same.
v.addEventListener("timeupdate", () => { if (v.currentTime > 0 && v.currentTime >= v.duration) done(); });
v.src = "VIDEO"; v.play().catch((e) => { out.textContent = "refused " + e.name; });
</script>"""


def _chromium_result(page: Path) -> str:
    proc = subprocess.run(
        [
            CHROMIUM,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--allow-file-access-from-files",
            "--virtual-time-budget=60000",
            "--dump-dom",
            page.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    found = proc.stdout.split('<pre id="out">', 1)
    return found[1].split("<", 1)[0] if len(found) == 2 else proc.stdout + proc.stderr


@pytest.mark.parametrize("suffix", [".mp4", ".webm"])
def test_chromium_plays_the_video_to_the_end(videos, suffix, tmp_path):
    if not (os.path.exists(CHROMIUM) or shutil.which("chromium")):
        unavailable(f"the browser playback test needs Debian's chromium ({CHROMIUM})")
    path, laps = videos[suffix]
    page = path.with_name(f"play{suffix}.html")
    page.write_text(PAGE.replace("VIDEO", path.name), encoding="utf-8")
    result = _chromium_result(page)
    width = laps[0][0].shape[1] // 2 * 2
    frames = sum(len(lap) for lap in laps)
    assert result == f"ended {width}x480 {frames / 5.0:.1f}", result
    # A control: an MPEG-4 Part 2 file (what OpenCV writes) is refused, so the check can fail.
    mp4v = tmp_path / "mp4v.mp4"
    writer = cv2.VideoWriter(str(mp4v), cv2.VideoWriter_fourcc(*"mp4v"), 5.0, (64, 48))
    for i in range(5):
        writer.write(np.full((48, 64, 3), 40 * i, np.uint8))
    writer.release()
    control = tmp_path / "control.html"
    control.write_text(PAGE.replace("VIDEO", mp4v.name), encoding="utf-8")
    assert not _chromium_result(control).startswith("ended")
