"""Camera sources against a loopback MJPEG/snapshot HTTP server and a small video file.

``MjpegServer`` streams ``multipart/x-mixed-replace`` JPEG frames like a phone camera app and can
be told to stall; ``test_hardware_env.py`` reuses it.
"""

from __future__ import annotations

import http.server
import threading
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from lfd_track.errors import LfdTrackError
from lfd_track.hardware.camera import (
    FRAME_SHAPE,
    CameraError,
    CameraTimeout,
    MjpegStreamSource,
    SnapshotSource,
    VideoFileSource,
    open_camera,
    to_observation,
)

BOUNDARY = b"lfdframe"


def gray_frame(index: int, shape: tuple[int, int] = (480, 640)) -> np.ndarray:
    """A BGR frame whose gray level encodes ``index`` (JPEG keeps flat gray within a few levels)."""
    return np.full((*shape, 3), (index * 8) % 256, np.uint8)


def frame_index(rgb: np.ndarray) -> int:
    """Inverse of ``gray_frame`` (modulo 32)."""
    return int(round(float(rgb.mean()) / 8)) % 32


class MjpegServer:
    """Loopback HTTP server: ``/video`` streams MJPEG, ``/shot.jpg`` serves one JPEG.

    ``make_frame(i)`` gives the i-th BGR frame; frames go out every ``period_s``. ``stall()`` stops
    sending (the connection stays open, as with a frozen phone app); ``resume()`` continues.
    ``frames_sent`` and ``last_sent_at`` (monotonic) describe the stream.
    """

    def __init__(
        self,
        make_frame: Callable[[int], np.ndarray] = gray_frame,
        period_s: float = 0.02,
    ) -> None:
        self.make_frame = make_frame
        self.period_s = period_s
        self.frames_sent = 0
        self.last_sent_at = 0.0
        self._running = threading.Event()
        self._running.set()
        self._closed = threading.Event()
        server = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def log_message(self, *args: object) -> None:
                pass

            def do_GET(self) -> None:  # noqa: N802 - http.server API
                if self.path.startswith("/shot.jpg"):
                    data = server._jpeg(server.frames_sent)
                    server.frames_sent += 1
                    self.send_response(200)
                    self.send_header("Content-Type", "image/jpeg")
                    self.send_header("Content-Length", str(len(data)))
                    self.end_headers()
                    self.wfile.write(data)
                    return
                if not self.path.startswith("/video"):
                    self.send_error(404)
                    return
                self.send_response(200)
                self.send_header(
                    "Content-Type", f"multipart/x-mixed-replace; boundary={BOUNDARY.decode()}"
                )
                self.end_headers()
                try:
                    while not server._closed.is_set():
                        if not server._running.is_set():
                            server._closed.wait(0.01)
                            continue
                        data = server._jpeg(server.frames_sent)
                        self.wfile.write(
                            b"--" + BOUNDARY + b"\r\nContent-Type: image/jpeg\r\n"
                            b"Content-Length: "
                            + str(len(data)).encode()
                            + b"\r\n\r\n"
                            + data
                            + b"\r\n"
                        )
                        self.wfile.flush()
                        server.frames_sent += 1
                        server.last_sent_at = time.monotonic()
                        server._closed.wait(server.period_s)
                except OSError:
                    return

        self._httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self._httpd.daemon_threads = True
        self._thread = threading.Thread(target=self._httpd.serve_forever, daemon=True)

    def _jpeg(self, index: int) -> bytes:
        ok, buf = cv2.imencode(".jpg", self.make_frame(index), [cv2.IMWRITE_JPEG_QUALITY, 90])
        assert ok
        return buf.tobytes()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self._httpd.server_address[1]}/video"

    @property
    def snapshot_url(self) -> str:
        return f"http://127.0.0.1:{self._httpd.server_address[1]}/shot.jpg"

    def stall(self) -> None:
        self._running.clear()

    def resume(self) -> None:
        self._running.set()

    def __enter__(self) -> MjpegServer:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._closed.set()
        self._httpd.shutdown()
        self._httpd.server_close()
        self._thread.join(timeout=5)


def test_to_observation_resizes_and_converts_to_rgb() -> None:
    bgr = np.zeros((240, 320, 3), np.uint8)
    bgr[..., 0] = 200  # blue in BGR
    obs = to_observation(bgr)
    assert obs.shape == FRAME_SHAPE and obs.dtype == np.uint8
    assert obs[..., 2].min() == 200 and obs[..., 0].max() == 0
    assert to_observation(np.zeros((960, 1280), np.uint8)).shape == FRAME_SHAPE


def test_open_camera_picks_the_source() -> None:
    assert isinstance(open_camera("http://phone:8080/shot.jpg?x=1"), SnapshotSource)
    assert isinstance(open_camera("https://phone/a/B.JPEG"), SnapshotSource)
    assert isinstance(open_camera("http://phone:8080/video"), MjpegStreamSource)
    assert isinstance(open_camera("rtsp://phone:8554/live"), MjpegStreamSource)
    assert isinstance(open_camera("runs/replay.avi"), VideoFileSource)


def test_ffmpeg_backend_reads_loopback_mjpeg_stream() -> None:
    with MjpegServer() as server, MjpegStreamSource(server.url) as camera:
        frames = [camera.read(timeout_s=3.0) for _ in range(3)]
    assert all(f.shape == FRAME_SHAPE and f.dtype == np.uint8 for f in frames)
    indices = [frame_index(f) for f in frames]
    assert indices == sorted(indices) and len(set(indices)) == 3  # each read is a new frame


def test_stream_keeps_only_the_newest_frame() -> None:
    with MjpegServer(period_s=0.01) as server, MjpegStreamSource(server.url) as camera:
        camera.read(timeout_s=3.0)
        start = server.frames_sent
        # Let frames pile up; a queue-like reader would return the oldest of them.
        assert _wait(lambda: server.frames_sent >= start + 12)
        newest = frame_index(camera.read(timeout_s=3.0))
        sent = server.frames_sent
    assert (sent - 1 - newest) % 32 <= 4
    assert camera.frames_received >= 10


def test_latest_shows_the_newest_frame_without_taking_it() -> None:
    # One frame every 2 s: a read that had to wait for the next frame would time out below.
    with MjpegServer(period_s=2.0) as server, MjpegStreamSource(server.url) as camera:
        assert _wait(lambda: camera.latest() is not None)
        number, shown = camera.latest()
        assert camera.latest()[0] == number  # looking twice takes nothing
        taken = camera.read(timeout_s=0.3)  # the control loop still gets the frame at once
        assert taken is shown or camera.frames_received > number


def test_stalled_stream_raises_camera_timeout_then_recovers() -> None:
    with MjpegServer() as server, MjpegStreamSource(server.url, read_timeout_s=0.5) as camera:
        camera.read(timeout_s=3.0)
        server.stall()
        with pytest.raises(CameraTimeout, match="no new frame"):
            for _ in range(50):
                camera.read(timeout_s=0.3)
        assert camera.seconds_since_frame() >= 0.3
        server.resume()
        assert camera.read(timeout_s=5.0).shape == FRAME_SHAPE


def test_unreachable_stream_is_a_camera_error() -> None:
    with MjpegServer() as server:
        url = server.url.replace("/video", "/nothing")
        with pytest.raises(CameraError), MjpegStreamSource(url, open_timeout_s=1.0):
            pass
    assert issubclass(CameraError, LfdTrackError)


def test_snapshot_source_polls_new_frames() -> None:
    with MjpegServer() as server, open_camera(server.snapshot_url) as camera:
        assert isinstance(camera, SnapshotSource)
        a, b = camera.read(timeout_s=3.0), camera.read(timeout_s=3.0)
    assert a.shape == b.shape == FRAME_SHAPE
    assert frame_index(a) != frame_index(b)


def test_video_file_source_replays_in_order(tmp_path: Path) -> None:
    path = tmp_path / "replay.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (320, 240))
    assert writer.isOpened()
    for i in range(4):
        writer.write(gray_frame(i, (240, 320)))
    writer.release()
    with open_camera(path) as camera:
        indices = [frame_index(camera.read()) for _ in range(4)]
        with pytest.raises(CameraTimeout, match="end of the video"):
            camera.read()
    assert indices == [0, 1, 2, 3]
    with VideoFileSource(path, loop=True) as camera:
        assert [frame_index(camera.read()) for _ in range(5)] == [0, 1, 2, 3, 0]
    with pytest.raises(CameraError, match="no such video file"):
        VideoFileSource(tmp_path / "missing.avi").open()


def _wait(predicate: Callable[[], bool], timeout_s: float = 5.0) -> bool:
    """Poll ``predicate`` (state owned by a server thread without a condition to wait on)."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True
