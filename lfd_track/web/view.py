"""What the page shows of a frame: the paper's Fig. 2 overlay and the simulator's map, as JPEG."""

from __future__ import annotations

import cv2
import numpy as np

from ..vision.overlay import draw_road_values
from .contract import View

JPEG_QUALITY = 80
TOPDOWN_WIDTH_PX = 360  # [px] the map is an inset; its labels stay readable at this width


def encode_jpeg(rgb: np.ndarray, quality: int = JPEG_QUALITY) -> bytes:
    """JPEG bytes of an RGB uint8 (H, W, 3) picture."""
    ok, buf = cv2.imencode(
        ".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, int(quality)]
    )
    if not ok:  # pragma: no cover - OpenCV always encodes a valid uint8 picture
        raise RuntimeError("JPEG encoding failed")
    return buf.tobytes()


def make_view(
    seq: int,
    frame: np.ndarray,
    road_values: np.ndarray,
    topdown: np.ndarray | None = None,
    caption: str = "",
) -> View:
    """The page's view of one frame.

    ``frame``: RGB uint8 (480, 640, 3) camera frame; ``road_values``: (40,) values to draw over
    it (computed by the caller; drawing never touches the road library); ``topdown``: RGB uint8
    map picture or None; ``caption``: one line written at the bottom of the camera view.
    """
    camera = draw_road_values(frame, road_values)
    if caption:
        cv2.putText(
            camera, caption, (8, camera.shape[0] - 10), cv2.FONT_HERSHEY_SIMPLEX, 0.6,
            (0, 0, 0), 3, cv2.LINE_AA,
        )  # fmt: skip
        cv2.putText(
            camera, caption, (8, camera.shape[0] - 10), cv2.FONT_HERSHEY_SIMPLEX, 0.6,
            (255, 255, 255), 1, cv2.LINE_AA,
        )  # fmt: skip
    top = None
    if topdown is not None:
        scale = TOPDOWN_WIDTH_PX / topdown.shape[1]
        small = cv2.resize(
            topdown,
            (TOPDOWN_WIDTH_PX, max(int(round(topdown.shape[0] * scale)), 1)),
            interpolation=cv2.INTER_AREA,
        )
        top = encode_jpeg(small)
    return View(seq=seq, camera_jpeg=encode_jpeg(camera), topdown_jpeg=top)
