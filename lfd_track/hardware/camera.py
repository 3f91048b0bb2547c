"""Frame sources for the real robot: a phone's MJPEG stream, JPEG snapshots, or a video file.

Every source has the same small interface (``open()``, ``read(timeout_s)``, ``close()``, context
manager) and returns what the simulated env returns: RGB ``uint8`` arrays of shape (480, 640, 3),
resized if the camera sends another size.

Live sources (``MjpegStreamSource``, ``SnapshotSource``) read in a background thread that keeps
only the newest frame: a phone streams faster than the 2.5 Hz control loop consumes, and a plain
blocking ``read()`` on the stream would hand out frames that queued up seconds ago. ``read()``
returns the newest frame not returned before, waiting for one if needed, and raises
``CameraTimeout`` when no new frame arrived for ``timeout_s`` seconds.

MJPEG over HTTP is read with OpenCV's FFmpeg backend (``cv2.CAP_FFMPEG``), with open and read
timeouts set so a stalled phone cannot block the reader forever. The pip build of
``opencv-python-headless`` (5.0.0 checked here) ships FFmpeg and reads a
``multipart/x-mixed-replace`` JPEG stream over plain HTTP, so no separate multipart parser is
needed; ``tests/hardware/test_camera.py`` checks exactly that against a loopback server.
"""

from __future__ import annotations

import http.client
import os
import socket
import threading
import time
import urllib.error
import urllib.request
from abc import ABC, abstractmethod
from functools import partial
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from ..errors import LfdTrackError

FRAME_SHAPE = (480, 640, 3)  # (height, width, RGB) of every frame handed out
MAX_SNAPSHOT_BYTES = 16 * 1024 * 1024  # a phone's full-resolution JPEG is a few MB


class CameraError(LfdTrackError):
    """A camera source cannot be opened or read."""


class CameraTimeout(CameraError):
    """No new frame arrived in time (stalled stream, phone app stopped, Wi-Fi lost)."""


def to_observation(frame_bgr: np.ndarray) -> np.ndarray:
    """Convert a decoded OpenCV frame (H, W, 3) BGR (or (H, W) gray) to RGB uint8 (480, 640, 3)."""
    if frame_bgr.ndim == 2:
        frame_bgr = cv2.cvtColor(frame_bgr, cv2.COLOR_GRAY2BGR)
    elif frame_bgr.shape[2] == 4:
        frame_bgr = cv2.cvtColor(frame_bgr, cv2.COLOR_BGRA2BGR)
    if frame_bgr.dtype != np.uint8:
        raise CameraError(f"camera frame has dtype {frame_bgr.dtype}, expected uint8")
    height, width = FRAME_SHAPE[:2]
    if frame_bgr.shape[:2] != (height, width):
        shrinking = frame_bgr.shape[0] > height
        interpolation = cv2.INTER_AREA if shrinking else cv2.INTER_LINEAR
        frame_bgr = cv2.resize(frame_bgr, (width, height), interpolation=interpolation)
    return np.ascontiguousarray(cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2RGB))


class FrameSource(ABC):
    """A camera: ``open()``, ``read(timeout_s)`` → RGB uint8 (480, 640, 3), ``close()``."""

    name: str

    def __enter__(self) -> FrameSource:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @abstractmethod
    def open(self) -> None:
        """Start the source; raises ``CameraError`` if it cannot be opened."""

    @abstractmethod
    def read(self, timeout_s: float = 1.0) -> np.ndarray:
        """The newest frame not returned before, RGB uint8 (480, 640, 3).

        Raises ``CameraTimeout`` if none arrives within ``timeout_s`` [s].
        """

    @abstractmethod
    def close(self) -> None:
        """Stop the source and release it (idempotent)."""

    def seconds_since_frame(self) -> float:
        """Time since the last frame arrived [s] (0 for sources that are not live)."""
        return 0.0


class _LatestFrameSource(FrameSource):
    """A live source: a background thread grabs frames, only the newest one is kept."""

    def __init__(self, name: str, *, open_timeout_s: float, read_timeout_s: float) -> None:
        self.name = name
        self.open_timeout_s = open_timeout_s
        self.read_timeout_s = read_timeout_s
        self._cond = threading.Condition()
        self._frame: np.ndarray | None = None
        self._frame_id = 0  # increments with every frame received
        self._returned_id = 0  # id of the frame last handed out by read()
        self._frame_time = 0.0  # monotonic arrival time of the newest frame
        self._error: str | None = None  # last reader problem, for the timeout message
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._old_thread: threading.Thread | None = None

    @property
    def frames_received(self) -> int:
        """Frames decoded by the background reader since ``open()``."""
        return self._frame_id

    def open(self) -> None:
        if self._thread is not None:
            return
        old = self._old_thread
        if old is not None and old.is_alive():
            # A reader from before close() still finishing a blocking read: it owns the stream
            # until it returns (at most the read/open timeout).
            old.join()
        self._stop = threading.Event()
        self._connect()
        self._frame_time = time.monotonic()  # the timeout clock starts at open
        self._thread = threading.Thread(
            target=self._run, args=(self._stop,), name=f"lfd-track camera {self.name}", daemon=True
        )
        self._thread.start()

    def close(self) -> None:
        """Stop the reader; it releases the stream itself once its current read returns.

        A stalled stream can block the reader for up to the read (or reconnect) timeout; close()
        waits only briefly for it, so stopping the robot never waits on the camera.
        """
        self._stop.set()
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join(timeout=0.5)
            self._old_thread = thread
        with self._cond:
            self._cond.notify_all()

    def read(self, timeout_s: float = 1.0) -> np.ndarray:
        if self._thread is None:
            raise CameraError(f"{self.name}: camera is not open")
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while self._frame_id == self._returned_id:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or self._thread is None:
                    detail = f" ({self._error})" if self._error else ""
                    raise CameraTimeout(
                        f"{self.name}: no new frame for {self.seconds_since_frame():.1f} s"
                        f"{detail}; is the phone's camera app streaming?"
                    )
                self._cond.wait(remaining)
            self._returned_id = self._frame_id
            assert self._frame is not None
            return self._frame

    def seconds_since_frame(self) -> float:
        return time.monotonic() - self._frame_time

    def latest(self) -> tuple[int, np.ndarray] | None:
        """The newest frame (RGB uint8 (480, 640, 3)) and its number, or None before the first.

        For previews: unlike :meth:`read` it does not take the frame, so the control loop's next
        ``read`` still gets it.
        """
        with self._cond:
            return None if self._frame is None else (self._frame_id, self._frame)

    def _publish(self, frame_bgr: np.ndarray) -> None:
        observation = to_observation(frame_bgr)
        with self._cond:
            self._frame = observation
            self._frame_id += 1
            self._frame_time = time.monotonic()
            self._error = None
            self._cond.notify_all()

    def _run(self, stop: threading.Event) -> None:
        """Reader thread: owns the stream from open() until it sees ``stop`` and releases it."""
        try:
            while not stop.is_set():
                try:
                    frame = self._grab()
                except Exception as exc:  # noqa: BLE001 - reported through read()'s timeout
                    frame = None
                    self._error = str(exc) or type(exc).__name__
                if frame is not None:
                    if not stop.is_set():
                        self._publish(frame)
                    continue
                # The stream ended or stalled past its read timeout: reconnect (a phone app that
                # restarted serves again), without spinning while the phone is away.
                self._disconnect()
                if stop.wait(0.2):
                    break
                try:
                    self._connect()
                except CameraError as exc:
                    self._error = str(exc)
        finally:
            self._disconnect()

    @abstractmethod
    def _connect(self) -> None: ...

    @abstractmethod
    def _disconnect(self) -> None: ...

    @abstractmethod
    def _grab(self) -> np.ndarray | None:
        """Block for the next decoded BGR frame; None if the stream failed or stalled."""


def _quiet_opencv_logs() -> None:
    """Keep OpenCV's and FFmpeg's own warnings off stderr (a user's settings win).

    They add lines of their own to every unreachable, stalled or corrupt stream, which
    ``CameraError``/``CameraTimeout`` already name in one line. FFmpeg's level is read when
    OpenCV first starts FFmpeg, so this runs before the first capture opens.
    """
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET
    if "OPENCV_LOG_LEVEL" not in os.environ:
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)


class MjpegStreamSource(_LatestFrameSource):
    """A phone's MJPEG stream (IP Webcam ``http://PHONE:8080/video``, DroidCam ``:4747/video``).

    Read through OpenCV's FFmpeg backend with open/read timeouts [s].
    """

    def __init__(self, url: str, *, open_timeout_s: float = 5.0, read_timeout_s: float = 1.0):
        super().__init__(url, open_timeout_s=open_timeout_s, read_timeout_s=read_timeout_s)
        self.url = url
        self._capture: Any = None

    def _connect(self) -> None:
        params = [
            cv2.CAP_PROP_OPEN_TIMEOUT_MSEC,
            int(self.open_timeout_s * 1000),
            cv2.CAP_PROP_READ_TIMEOUT_MSEC,
            int(self.read_timeout_s * 1000),
        ]
        _quiet_opencv_logs()
        capture = cv2.VideoCapture(self.url, cv2.CAP_FFMPEG, params)
        if not capture.isOpened():
            capture.release()
            raise CameraError(f"{self.url}: cannot open the video stream (check the URL and app)")
        self._capture = capture

    def _disconnect(self) -> None:
        capture, self._capture = self._capture, None
        if capture is not None:
            capture.release()

    def _grab(self) -> np.ndarray | None:
        if self._capture is None:
            return None
        ok, frame = self._capture.read()
        return frame if ok and frame is not None else None


class SnapshotSource(_LatestFrameSource):
    """Polls a JPEG snapshot URL (IP Webcam ``http://PHONE:8080/shot.jpg``) with urllib.

    ``poll_period_s`` bounds the request rate [s]; each request has a ``read_timeout_s`` timeout.
    """

    def __init__(
        self,
        url: str,
        *,
        poll_period_s: float = 0.05,
        open_timeout_s: float = 5.0,
        read_timeout_s: float = 1.0,
    ) -> None:
        super().__init__(url, open_timeout_s=open_timeout_s, read_timeout_s=read_timeout_s)
        self.url = url
        self.poll_period_s = poll_period_s
        self._last_poll = 0.0

    def _fetch(self, timeout_s: float) -> np.ndarray:
        """One snapshot, decoded; the whole request (headers and body) takes at most ``timeout_s``.

        urllib's timeout bounds each socket read only: a peer that sends a byte now and then
        would hold the request forever, so a timer shuts the socket down at the deadline. Bodies
        over ``MAX_SNAPSHOT_BYTES`` are refused, not buffered.
        """
        deadline = _Deadline(timeout_s)
        opener = urllib.request.OpenerDirector()  # http(s) only: no redirect to ftp:// or file://
        for handler in (
            urllib.request.ProxyHandler(),
            urllib.request.UnknownHandler(),
            urllib.request.HTTPDefaultErrorHandler(),
            urllib.request.HTTPRedirectHandler(),
            urllib.request.HTTPErrorProcessor(),
            _WatchedHTTPHandler(deadline),
            _WatchedHTTPSHandler(deadline),
        ):
            opener.add_handler(handler)
        too_large = f"{self.url}: the snapshot is larger than {MAX_SNAPSHOT_BYTES // 2**20} MB"
        try:
            with deadline, opener.open(self.url, timeout=timeout_s) as response:
                if (response.length or 0) > MAX_SNAPSHOT_BYTES:
                    raise CameraError(too_large)
                data = response.read(MAX_SNAPSHOT_BYTES + 1)
        except (urllib.error.URLError, http.client.HTTPException, OSError, ValueError) as exc:
            if not deadline.expired:
                detail = " ".join(str(exc).split()) or type(exc).__name__  # one line
                raise CameraError(f"{self.url}: snapshot request failed ({detail})") from None
        if deadline.expired:  # the read may also have ended quietly, with the data cut short
            raise CameraError(f"{self.url}: no complete snapshot within {timeout_s:g} s")
        if len(data) > MAX_SNAPSHOT_BYTES:
            raise CameraError(too_large)
        frame = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
        if frame is None:
            raise CameraError(f"{self.url}: the snapshot is not a decodable image")
        return frame

    def _connect(self) -> None:
        # One snapshot proves the URL works; it becomes the first frame.
        self._publish(self._fetch(self.open_timeout_s))
        self._last_poll = time.monotonic()

    def _disconnect(self) -> None:
        pass

    def _grab(self) -> np.ndarray | None:
        wait_s = self._last_poll + self.poll_period_s - time.monotonic()
        if wait_s > 0 and self._stop.wait(wait_s):
            return None  # closing
        self._last_poll = time.monotonic()
        return self._fetch(self.read_timeout_s)


class _Deadline:
    """A context manager that shuts down the sockets it watches once ``timeout_s`` has passed.

    A blocked read on a shut-down socket returns at once; ``expired`` tells why it ended.
    """

    def __init__(self, timeout_s: float) -> None:
        self.expired = False
        self._sockets: list[socket.socket] = []
        self._lock = threading.Lock()
        self._timer = threading.Timer(timeout_s, self._expire)
        self._timer.daemon = True

    def __enter__(self) -> _Deadline:
        self._timer.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._timer.cancel()

    def watch(self, sock: socket.socket) -> None:
        with self._lock:
            self._sockets.append(sock)
            if self.expired:
                _shutdown(sock)

    def _expire(self) -> None:
        with self._lock:
            self.expired = True
            for sock in self._sockets:
                _shutdown(sock)


def _shutdown(sock: socket.socket) -> None:
    try:
        sock.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass  # already closed


class _Watched:
    """Mixed into an ``http.client`` connection, before it: its socket is watched by a
    :class:`_Deadline` from the moment it connects."""

    sock: socket.socket

    def __init__(self, *args: Any, deadline: _Deadline, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._deadline = deadline

    def connect(self) -> None:
        super().connect()  # type: ignore[misc]  # the connection class after the mixin has it
        self._deadline.watch(self.sock)


class _WatchedHTTPConnection(_Watched, http.client.HTTPConnection):
    pass


class _WatchedHTTPSConnection(_Watched, http.client.HTTPSConnection):
    pass


class _WatchedHTTPHandler(urllib.request.HTTPHandler):
    def __init__(self, deadline: _Deadline) -> None:
        super().__init__()
        self._deadline = deadline

    def http_open(self, req: urllib.request.Request) -> http.client.HTTPResponse:
        return self.do_open(partial(_WatchedHTTPConnection, deadline=self._deadline), req)


class _WatchedHTTPSHandler(urllib.request.HTTPSHandler):
    def __init__(self, deadline: _Deadline) -> None:
        super().__init__()
        self._deadline = deadline

    def https_open(self, req: urllib.request.Request) -> http.client.HTTPResponse:
        # As urllib's own https_open does: the handler's SSL context (not in typeshed).
        context = self._context  # type: ignore[attr-defined]
        return self.do_open(
            partial(_WatchedHTTPSConnection, deadline=self._deadline), req, context=context
        )


class VideoFileSource(FrameSource):
    """Frames of a video file, in order, one per ``read()`` (replay and tests).

    At the end of the file ``read()`` raises ``CameraTimeout``, or starts over with ``loop=True``.
    """

    def __init__(self, path: str | Path, *, loop: bool = False) -> None:
        self.path = Path(path)
        self.name = str(path)
        self.loop = loop
        self._capture: Any = None

    def open(self) -> None:
        if self._capture is not None:
            return
        if not self.path.is_file():
            raise CameraError(f"{self.path}: no such video file")
        capture = cv2.VideoCapture(str(self.path))
        if not capture.isOpened():
            capture.release()
            raise CameraError(f"{self.path}: cannot decode this video file")
        self._capture = capture

    def read(self, timeout_s: float = 1.0) -> np.ndarray:
        if self._capture is None:
            raise CameraError(f"{self.path}: video file is not open")
        ok, frame = self._capture.read()
        if not ok and self.loop:
            self._capture.set(cv2.CAP_PROP_POS_FRAMES, 0)
            ok, frame = self._capture.read()
        if not ok or frame is None:
            raise CameraTimeout(f"{self.path}: end of the video file")
        return to_observation(frame)

    def close(self) -> None:
        capture, self._capture = self._capture, None
        if capture is not None:
            capture.release()


def open_camera(url_or_path: str | Path, **kwargs: Any) -> FrameSource:
    """Pick a source for ``url_or_path`` (not opened yet).

    An http(s) URL whose path ends in ``.jpg``/``.jpeg`` → ``SnapshotSource``; any other URL
    (``http://PHONE:8080/video``, ``rtsp://…``) → ``MjpegStreamSource``; otherwise a video file
    path → ``VideoFileSource``. ``kwargs`` go to the source's constructor.
    """
    text = str(url_or_path)
    scheme, sep, rest = text.partition("://")
    if sep and scheme.isalpha():
        path = rest.split("?", 1)[0].split("#", 1)[0].lower()
        if scheme.lower() in ("http", "https") and path.endswith((".jpg", ".jpeg")):
            return SnapshotSource(text, **kwargs)
        return MjpegStreamSource(text, **kwargs)
    return VideoFileSource(text, **kwargs)
