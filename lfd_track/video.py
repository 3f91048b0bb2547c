"""MP4 videos of autonomous drives: camera view with the road-value overlay beside the top-down view."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from .render.topdown import draw_topdown
from .vision.overlay import draw_road_values


class DriveVideo:
    """Collects frames of a drive and writes them as an MP4 (atomically, on ``close``)."""

    def __init__(self, path: str | Path, env: Any, fps: float = 5.0) -> None:
        self.path = Path(path)
        self.env = env
        self.fps = fps
        # OpenCV takes the name as UTF-8 and crashes on one that is not (a non-UTF-8 byte in a
        # POSIX file name): write under an ASCII name in the same folder, then rename.
        self._tmp = self.path.with_name(f".lfd-track-video-{os.getpid()}.partial.mp4")
        self._writer: cv2.VideoWriter | None = None
        self._trajectory: list[tuple[float, float]] = []

    def add(self, frame: np.ndarray, road_values: np.ndarray, info: dict[str, Any]) -> None:
        """Append one step: the RGB camera frame, its (40,) road values and the env info."""
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
        text = f"progress {info['progress_m']:.2f} m  corners {' '.join(info['corners_negotiated']) or '-'}"
        cv2.putText(
            canvas,
            text,
            (camera.shape[1] + 10, camera.shape[0] - 12),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.6,
            (255, 255, 255),
            2,
            cv2.LINE_AA,
        )
        canvas = canvas[: canvas.shape[0] // 2 * 2, : canvas.shape[1] // 2 * 2]
        if self._writer is None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            fourcc = cv2.VideoWriter_fourcc(*"mp4v")
            self._writer = cv2.VideoWriter(
                str(self._tmp), fourcc, self.fps, (canvas.shape[1], canvas.shape[0])
            )
            if not self._writer.isOpened():
                raise OSError(
                    f"{self.path}: cannot open an MP4 writer (OpenCV built without FFmpeg?)"
                )
        self._writer.write(cv2.cvtColor(canvas, cv2.COLOR_RGB2BGR))

    def close(self) -> None:
        """Finish the file and move it into place."""
        if self._writer is not None:
            self._writer.release()
            self._writer = None
            os.replace(self._tmp, self.path)
