"""Videos of autonomous drives: camera view with the road-value overlay beside the top-down view.

Browsers play the files: ``.mp4`` is H.264 (yuv420p, index at the front for streaming) and
``.webm`` is VP9. They are encoded by the FFmpeg binary of the ``imageio-ffmpeg`` package: the
OpenCV wheels write only MPEG-4 Part 2 ("mp4v", which browsers do not play) or a VP9 too slow to
encode (about 0.5 s per frame). Each frame is labelled with the lap number and the command chosen
for it, and the top-down trajectory starts afresh with each lap.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from ..core.commands import Command
from ..render.topdown import draw_topdown
from ..utils.atomic import replace_file
from ..utils.extras import needs_extra
from ..utils.outputs import refuse_unsafe_output, shown_path, unwritable_name
from ..vision.overlay import draw_road_values

#: File suffix → (FFmpeg encoder, its options). Fast presets: a drive's video should cost about
#: as much time as the drive.
VIDEO_FORMATS: dict[str, tuple[str, list[str]]] = {
    ".mp4": ("libx264", ["-preset", "veryfast", "-crf", "23", "-movflags", "+faststart"]),
    ".webm": ("libvpx-vp9", ["-deadline", "realtime", "-cpu-used", "8", "-b:v", "0", "-crf", "32"]),
}


def _label(canvas: np.ndarray, text: str, org: tuple[int, int], scale: float = 0.6) -> None:
    """White text with a dark outline, readable on felt, carpet and overlay alike."""
    text = shown_path(text)  # OpenCV crashes on text that is not UTF-8
    for colour, thickness in (((0, 0, 0), 4), ((255, 255, 255), 2)):
        cv2.putText(
            canvas, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, colour, thickness, cv2.LINE_AA
        )


class DriveVideo:
    """Writes the frames of a drive as a video; the file appears (atomically) on ``close``.

    Until then it is written to a temporary file beside it; :meth:`discard` (an interrupted or
    failed drive) deletes that file and leaves any earlier file of that name untouched.

    Raises ValueError for a file name that is not ``.mp4`` (H.264) or ``.webm`` (VP9), OSError for
    a name that is a folder or lies below a file.
    """

    def __init__(self, path: str | Path, env: Any, fps: float = 5.0) -> None:
        self.path = Path(path)
        suffix = self.path.suffix.lower()
        if suffix not in VIDEO_FORMATS:
            raise ValueError(f"{self.path}: a video name must end in .mp4 (H.264) or .webm (VP9)")
        refuse_unsafe_output(self.path)
        problem = unwritable_name(self.path, "video file")
        if problem is not None:
            raise OSError(*problem, str(self.path))  # IsADirectoryError, NotADirectoryError
        self.codec, self._options = VIDEO_FORMATS[suffix]
        self.env = env
        self.fps = fps
        # Written under an ASCII name in the same folder, then renamed: a file name that is not
        # UTF-8 (a stray byte in a POSIX name) never reaches the encoder.
        self._tmp = self.path.with_name(f".lfd-track-video-{os.getpid()}.partial{suffix}")
        self._writer: Any = None  # imageio_ffmpeg.write_frames generator, once a frame arrives
        self._trajectory: list[tuple[float, float]] = []
        self._lap: int | None = None

    def compose(
        self,
        frame: np.ndarray,
        road_values: np.ndarray,
        info: dict[str, Any],
        *,
        lap: int = 1,
        command: int | None = None,
    ) -> np.ndarray:
        """One video frame, (480, W, 3) uint8 RGB, for a step; also extends the lap's trajectory.

        Inputs: the RGB camera frame, its (40,) road values and the env info. ``lap`` numbers the
        episode (a new number clears the drawn trajectory); ``command`` is the command chosen for
        this frame (0 forward, 1 left, 2 right) or None if unknown.
        """
        if lap != self._lap:
            self._lap = lap
            self._trajectory = []
        camera = draw_road_values(frame, road_values)
        self._trajectory.append(tuple(info["pose"][:2]))
        pose = np.asarray(info["pose"])
        top = draw_topdown(
            self.env.track,
            pose=pose,
            trajectory=np.asarray(self._trajectory),
            footprint=self.env.camera_footprint(pose),
            size_px=(camera.shape[0] * 4 // 3, camera.shape[0]),
        )
        if top.shape[0] != camera.shape[0]:
            scale = camera.shape[0] / top.shape[0]
            top = cv2.resize(top, (int(top.shape[1] * scale), camera.shape[0]))
        canvas = np.concatenate([camera, top], axis=1)
        name = "-" if command is None else Command(int(command)).name.lower()
        # On the top-down half: the camera half is covered by the road values.
        caption = f"lap {lap}   step {info['step']}   command: {name}"
        _label(canvas, caption, (camera.shape[1] + 10, 28), 0.7)
        corners = " ".join(info["corners_negotiated"]) or "-"
        _label(
            canvas,
            f"progress {info['progress_m']:.2f} m  corners {corners}",
            (camera.shape[1] + 10, camera.shape[0] - 12),
        )
        return canvas

    def add(
        self,
        frame: np.ndarray,
        road_values: np.ndarray,
        info: dict[str, Any],
        *,
        lap: int = 1,
        command: int | None = None,
    ) -> None:
        """Append one step (arguments as for :meth:`compose`) to the video."""
        canvas = self.compose(frame, road_values, info, lap=lap, command=command)
        canvas = canvas[: canvas.shape[0] // 2 * 2, : canvas.shape[1] // 2 * 2]
        if self._writer is None:
            with needs_extra("video"):
                import imageio_ffmpeg

            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._writer = imageio_ffmpeg.write_frames(
                str(self._tmp),
                (canvas.shape[1], canvas.shape[0]),
                fps=self.fps,
                codec=self.codec,
                pix_fmt_in="rgb24",
                pix_fmt_out="yuv420p",
                output_params=self._options,
                macro_block_size=2,
                ffmpeg_log_level="error",
            )
            self._writer.send(None)  # starts the encoder process
        try:
            self._writer.send(np.ascontiguousarray(canvas))
        except (OSError, RuntimeError) as exc:
            self._writer = None
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise OSError(f"{self.path}: video encoding failed ({first})") from None

    def close(self) -> None:
        """Finish the file and move it into place (if a frame was added)."""
        if self._writer is not None:
            writer, self._writer = self._writer, None
            try:
                writer.close()  # waits for the encoder to finish the file
                replace_file(self._tmp, self.path)
            except BaseException:
                self._tmp.unlink(missing_ok=True)
                raise

    def discard(self) -> None:
        """Stop the encoder and delete the unfinished video; an earlier file stays as it was."""
        writer, self._writer = self._writer, None
        try:
            if writer is not None:
                try:
                    writer.throw(_Discard())  # the encoder is killed, not waited for
                except (_Discard, StopIteration, OSError, RuntimeError):
                    pass
        finally:
            self._tmp.unlink(missing_ok=True)


class _Discard(BaseException):
    """Thrown into the encoder's generator: imageio-ffmpeg kills FFmpeg for a BaseException."""
