"""Pictures for reports: fitness curves and trajectory maps, drawn with OpenCV (no matplotlib).

Every picture explains itself: titles say what is shown, legends give colours and counts, track
pictures carry a metre scale, the start arrow and the finish line.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from ..render.topdown import RGB, TopDownView
from ..utils.outputs import shown_path
from ..world.track import Track

SUCCESS_RGB: RGB = (40, 170, 60)
FAILURE_RGB: RGB = (215, 40, 40)
OFF_TRACK_RGB: RGB = (150, 60, 200)
TIMEOUT_RGB: RGB = (240, 160, 20)
MARK_RGB: RGB = (255, 255, 255)
INK: RGB = (0, 0, 0)
GREY: RGB = (90, 90, 90)
FONT = cv2.FONT_HERSHEY_SIMPLEX

#: Outcome → (colour, legend name); the order of the legend.
OUTCOMES: dict[str | None, tuple[RGB, str]] = {
    None: (SUCCESS_RGB, "success"),
    "reversed": (FAILURE_RGB, "reversed"),
    "off_track": (OFF_TRACK_RGB, "off the felt"),
    "timeout": (TIMEOUT_RGB, "timeout (step budget used up)"),
}


def outcome_colour(success: bool, failure: str | None) -> RGB:
    """Green for a success, red for reversing, purple for leaving the felt, orange for a timeout."""
    if success:
        return SUCCESS_RGB
    return OUTCOMES.get(failure, (FAILURE_RGB, ""))[0]


# ------------------------------------------------------------------------------- drawing aids
def _text(
    img: np.ndarray,
    text: str,
    org: tuple[int, int],
    scale: float = 0.5,
    colour: RGB = INK,
    thickness: int = 1,
) -> None:
    """Draw ``text``; bytes that are not UTF-8 are drawn as \\x escapes (OpenCV would crash)."""
    cv2.putText(img, shown_path(text), org, FONT, scale, colour, thickness, cv2.LINE_AA)


def _text_width(text: str, scale: float = 0.5, thickness: int = 1) -> int:
    return cv2.getTextSize(shown_path(text), FONT, scale, thickness)[0][0]


def _header(
    width: int, lines: Sequence[str], scale: float = 0.5, first_scale: float = 0.6
) -> np.ndarray:
    """White strip with one line of text per entry (the first one larger)."""
    heights = [int(28 * (first_scale if i == 0 else scale) / 0.5) for i in range(len(lines))]
    img = np.full((sum(heights) + 8, width, 3), 255, np.uint8)
    y = 0
    for i, (line, h) in enumerate(zip(lines, heights, strict=True)):
        y += h
        _text(img, line, (10, y - 8), first_scale if i == 0 else scale, INK, 2 if i == 0 else 1)
    return img


def nice_ticks(lo: float, hi: float, target: int = 5) -> np.ndarray:
    """Round tick values (1, 2, 2.5 or 5 × 10^k apart) covering [lo, hi], about ``target`` of them."""
    span = max(hi - lo, 1e-9)
    raw = span / max(target, 1)
    base = 10.0 ** math.floor(math.log10(raw))
    step = next(m * base for m in (1.0, 2.0, 2.5, 5.0, 10.0) if m * base >= raw)
    start = math.floor(lo / step + 1e-9) * step
    stop = math.ceil(hi / step - 1e-9) * step
    return np.round(np.arange(start, stop + step / 2, step), 10)


def _tick_label(value: float) -> str:
    return f"{value:g}"


def stack_images(images: Sequence[np.ndarray], *, vertical: bool = False) -> np.ndarray:
    """Place RGB images side by side (or stacked), padding with white to a common size."""
    if vertical:
        width = max(i.shape[1] for i in images)
        padded = [
            np.pad(i, ((0, 0), (0, width - i.shape[1]), (0, 0)), constant_values=255)
            for i in images
        ]
        return np.concatenate(padded, axis=0)
    height = max(i.shape[0] for i in images)
    padded = [
        np.pad(i, ((0, height - i.shape[0]), (0, 0), (0, 0)), constant_values=255) for i in images
    ]
    return np.concatenate(padded, axis=1)


# ------------------------------------------------------------------------------- fitness
def fitness_plot(
    curves: Sequence[tuple[str, np.ndarray, RGB]],
    *,
    size_px: tuple[int, int] = (760, 460),
    title: str = "Fitness per generation",
    notes: Sequence[str] = (),
    x_label: str = "generation",
) -> np.ndarray:
    """Line plot of fitness curves; ``curves`` holds (label, values (G,), RGB). Returns RGB uint8.

    The y axis is the paper's imitation fitness (weighted error: lower is better), from 0; the x
    axis counts generations (``x_label``) from 1. ``notes`` are extra lines under the title.
    """
    width, height = size_px
    header = _header(width, [title, *notes])
    plot_h_total = height - header.shape[0]
    img = np.full((max(plot_h_total, 160), width, 3), 255, np.uint8)
    height = img.shape[0]
    left, right, top, bottom = 70, 30, 12, 48
    plot_w, plot_h = width - left - right, height - top - bottom
    values = [np.asarray(v, dtype=float) for _, v, _ in curves if len(v)]
    if not values:
        return stack_images([header, img], vertical=True)
    hi = max(float(np.nanmax(v)) for v in values)
    y_ticks = nice_ticks(0.0, max(hi, 1e-6))
    lo, hi = 0.0, float(y_ticks[-1])
    n = max(len(v) for v in values)
    x_ticks = [t for t in nice_ticks(0, n) if t >= 0]
    x_ticks = [max(1, int(t)) for t in x_ticks if t <= n]

    def x_px(generation: np.ndarray | float) -> np.ndarray:
        return left + (np.asarray(generation, dtype=float) - 1) / max(n - 1, 1) * plot_w

    def y_px(value: np.ndarray | float) -> np.ndarray:
        return top + plot_h - (np.asarray(value, dtype=float) - lo) / (hi - lo) * plot_h

    for t in y_ticks:
        y = int(round(float(y_px(t))))
        cv2.line(img, (left, y), (left + plot_w, y), (225, 225, 225), 1)
        label = _tick_label(float(t))
        _text(img, label, (left - 8 - _text_width(label, 0.45), y + 5), 0.45)
    for t in x_ticks:
        x = int(round(float(x_px(t))))
        cv2.line(img, (x, top + plot_h), (x, top + plot_h + 5), INK, 1)
        label = str(t)
        _text(img, label, (x - _text_width(label, 0.45) // 2, top + plot_h + 20), 0.45)
    cv2.rectangle(img, (left, top), (left + plot_w, top + plot_h), INK, 1)
    xlabel = x_label
    _text(img, xlabel, (left + plot_w // 2 - _text_width(xlabel) // 2, height - 8), 0.5)
    ylabel = "fitness (lower is better)"
    strip = np.full((24, _text_width(ylabel) + 10, 3), 255, np.uint8)
    _text(strip, ylabel, (5, 17), 0.5)
    strip = np.rot90(strip)
    y0 = top + max((plot_h - strip.shape[0]) // 2, 0)
    h = min(strip.shape[0], img.shape[0] - y0)
    img[y0 : y0 + h, 2 : 2 + strip.shape[1]] = strip[:h]

    for _, curve, colour in curves:
        curve = np.asarray(curve, dtype=float)
        if len(curve) < 2:
            continue
        pts = np.stack([x_px(np.arange(1, len(curve) + 1)), y_px(curve)], axis=1)
        cv2.polylines(img, [pts.round().astype(np.int32)], False, colour, 1, cv2.LINE_AA)
    labelled = [(label, colour) for label, _, colour in curves if label]
    columns = 1 if len(labelled) <= 5 else 2
    per_column = math.ceil(len(labelled) / columns) if labelled else 0
    col_w = 90
    x0 = left + plot_w - columns * col_w - 4
    for i, (label, colour) in enumerate(labelled):
        x = x0 + (i // per_column) * col_w
        y = top + 18 + 18 * (i % per_column)
        cv2.line(img, (x, y - 5), (x + 20, y - 5), colour, 2)
        _text(img, label, (x + 25, y), 0.45)
    return stack_images([header, img], vertical=True)


def fitness_notes(elitism: int) -> list[str]:
    """Lines explaining a fitness plot's curves (why a best-of-generation curve may rise)."""
    if elitism > 0:
        return [f"The best {elitism} of each generation are kept, so the best curve never rises."]
    return [
        "Each generation is replaced whole (no elitism, as in the paper): a generation's best",
        "can be lost, so the best-of-generation curve may rise from one generation to the next.",
    ]


# ------------------------------------------------------------------------------- track maps
@dataclass(frozen=True)
class TrackRun:
    """One drive over a track for a picture: its path and how it ended."""

    path: np.ndarray
    """(T, 2) or (T, 3) float poses [m]; only x, y are drawn."""
    success: bool
    failure: str | None
    """"reversed", "off_track", "timeout" or None."""
    label: str = ""
    """Written where the path ends (e.g. "lap 2"); empty for none."""


def _finish_and_scale(
    view: TopDownView, img: np.ndarray, track: Track, finish_m: float | None
) -> None:
    """Finish line across the felt at ``finish_m`` along the track, and a 1 m scale bar."""
    if finish_m is not None:
        point, heading = track.point_at(
            float(finish_m) % track.length_m if track.closed else finish_m
        )
        normal = np.array([-math.sin(heading), math.cos(heading)])
        half = track.width_m * 0.5 + 0.04
        a, b = view.to_px(point + normal * half), view.to_px(point - normal * half)
        cv2.line(img, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), MARK_RGB, 3, cv2.LINE_AA)
    width, height = view.size_px
    bar = int(round(view.px_per_m))
    x0, y0 = 12, height - 14
    cv2.line(img, (x0, y0), (x0 + bar, y0), MARK_RGB, 2)
    for x in (x0, x0 + bar):
        cv2.line(img, (x, y0 - 5), (x, y0 + 3), MARK_RGB, 2)
    _text(img, "1 m", (x0 + bar // 2 - 12, y0 - 8), 0.45, MARK_RGB)


def _track_picture(
    track: Track,
    runs: Sequence[TrackRun],
    *,
    width_px: int,
    finish_m: float | None,
    start_pose: np.ndarray | None = None,
    thickness: int = 2,
) -> np.ndarray:
    view = TopDownView(track, width_px, margin_m=0.35)
    img = view.blank(track)
    _finish_and_scale(view, img, track, finish_m)
    for run in runs:
        colour = outcome_colour(run.success, run.failure)
        pts = np.asarray(run.path, dtype=np.float64)[:, :2]
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        view.draw_path(img, pts, colour, thickness)
        if len(pts):
            end = view.to_px(pts[-1])
            cv2.circle(img, (int(end[0]), int(end[1])), thickness + 3, colour, -1, cv2.LINE_AA)
            cv2.circle(img, (int(end[0]), int(end[1])), thickness + 3, MARK_RGB, 1, cv2.LINE_AA)
    if start_pose is not None:  # on top of the paths, which all begin there
        x, y, theta = (float(v) for v in start_pose)
        a = view.to_px(np.array([x, y]))
        b = view.to_px(np.array([x + 0.3 * math.cos(theta), y + 0.3 * math.sin(theta)]))
        for colour, width in ((INK, 5), (MARK_RGB, 2)):
            cv2.arrowedLine(
                img,
                (int(a[0]), int(a[1])),
                (int(b[0]), int(b[1])),
                colour,
                width,
                cv2.LINE_AA,
                tipLength=0.35,
            )
    for run in runs:  # labels last, so no path hides them
        pts = np.asarray(run.path, dtype=np.float64)[:, :2]
        if run.label and len(pts):
            end = view.to_px(pts[-1])
            org = (int(end[0]) + 8, int(end[1]) - 8)
            cv2.putText(img, shown_path(run.label), org, FONT, 0.5, INK, 3, cv2.LINE_AA)
            _text(img, run.label, org, 0.5, MARK_RGB)
    return img


def _counts_text(runs: Sequence[TrackRun], kinds: Sequence[str | None]) -> str:
    parts = []
    for kind in kinds:
        n = sum((r.failure if not r.success else None) == kind for r in runs)
        parts.append(f"{n} {OUTCOMES[kind][1].split(' (')[0]}")
    return ", ".join(parts)


def legend_strip(width: int, extra: Sequence[str] = ()) -> np.ndarray:
    """Key to the track pictures: outcome colours, marks and the scale bar."""
    rows: list[tuple[RGB | None, str]] = [(colour, name) for colour, name in OUTCOMES.values()]
    rows += [
        (None, "arrow: start and driving direction;  white bar across the felt: finish line"),
        (None, "dot: where a run ended;  numbers beside the felt: corner labels;  bar: 1 m"),
    ]
    rows += [(None, line) for line in extra]
    img = np.full(
        (12 + 22 * math.ceil(len(OUTCOMES) / 2) + 22 * (len(rows) - len(OUTCOMES)), width, 3),
        255,
        np.uint8,
    )
    for i, (colour, name) in enumerate(OUTCOMES.values()):  # the first rows
        x = 10 + (i % 2) * (width // 2)
        y = 24 + 22 * (i // 2)
        cv2.line(img, (x, y - 5), (x + 28, y - 5), colour, 3)
        _text(img, name, (x + 36, y), 0.5)
    y = 24 + 22 * math.ceil(len(OUTCOMES) / 2)
    for _, line in rows[len(OUTCOMES) :]:
        _text(img, line, (10, y), 0.5, GREY)
        y += 22
    return img


@dataclass(frozen=True)
class DirectionRuns:
    """All runs of one track direction, for :func:`trajectory_grid`."""

    title: str
    """e.g. "Testing track, clockwise (laps start at corner 4)"."""
    track: Track
    """The track as driven (reversed when the direction is)."""
    runs: Sequence[TrackRun]
    finish_m: float | None = None
    """Progress along ``track`` where a run succeeds [m] (drawn as the finish line)."""
    start_pose: np.ndarray | None = None
    """(3,) x [m], y [m], theta [rad] where every run starts (drawn as an arrow)."""


def trajectory_grid(
    directions: Sequence[DirectionRuns], *, title: str, panel_px: int = 480
) -> np.ndarray:
    """Small multiples: one row per direction, successes left and the other runs right.

    Each panel's heading counts its runs, so failures are never hidden under successes (or the
    other way round). Returns an (H, W, 3) uint8 RGB picture.
    """
    failures = ("reversed", "off_track", "timeout")
    rows = []
    for d in directions:
        ok = [r for r in d.runs if r.success]
        bad = [r for r in d.runs if not r.success]
        total = len(d.runs)
        left = stack_images(
            [
                _header(panel_px, [d.title, f"successes: {len(ok)} of {total}"], first_scale=0.55),
                _track_picture(
                    d.track, ok, width_px=panel_px, finish_m=d.finish_m, start_pose=d.start_pose
                ),
            ],
            vertical=True,
        )
        right = stack_images(
            [
                _header(
                    panel_px,
                    [" ", f"not successful: {len(bad)} of {total} ({_counts_text(bad, failures)})"],
                    first_scale=0.55,
                ),
                _track_picture(
                    d.track, bad, width_px=panel_px, finish_m=d.finish_m, start_pose=d.start_pose
                ),
            ],
            vertical=True,
        )
        gap = np.full((left.shape[0], 12, 3), 255, np.uint8)
        rows.append(stack_images([left, gap, right]))
        rows.append(np.full((10, 1, 3), 255, np.uint8))
    body = stack_images(rows, vertical=True)
    width = body.shape[1]
    return stack_images([_header(width, [title]), body, legend_strip(width)], vertical=True)


def laps_plot(
    track: Track,
    runs: Sequence[TrackRun],
    *,
    title: str,
    finish_m: float | None = None,
    start_pose: np.ndarray | None = None,
    width_px: int = 800,
) -> np.ndarray:
    """One track picture with every lap's path coloured by outcome and labelled "lap k".

    ``finish_m``: progress [m] of the finish line; ``start_pose``: (3,) start (x, y, theta).
    """
    counts = _counts_text(runs, list(OUTCOMES))
    picture = _track_picture(
        track, runs, width_px=width_px, finish_m=finish_m, start_pose=start_pose
    )
    header = _header(picture.shape[1], [title, f"{len(runs)} laps: {counts}"])
    return stack_images([header, picture, legend_strip(picture.shape[1])], vertical=True)


def write_png(path: str, rgb: np.ndarray) -> None:
    """Write an RGB image as PNG atomically."""
    from ..utils.atomic import atomic_write_bytes

    ok, buf = cv2.imencode(".png", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    if not ok:
        raise OSError(f"{path}: PNG encoding failed")
    atomic_write_bytes(path, buf.tobytes())
