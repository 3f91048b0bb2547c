"""``lfd-track tracks``: list the tracks a command can take, and draw one (a shipped track, a
file or a procedural loop such as ``random:test:17``) top-down, optionally writing it as a track
file, so a person can look at a loop a controller failed on."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from ..errors import LfdTrackError
from ..utils.data import data_dir
from ..utils.outputs import same_file, shown_path
from ..world.loops import DEFAULT_LOOPS, LOOPS_PER_SPLIT, SPLITS, loop_seed
from ..world.track import Track, load_track
from .outputs import check_output
from .types import EXIT_OK


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``tracks`` (``list`` and ``show``) to the ``lfd-track`` commands."""
    tracks = subparsers.add_parser(
        "tracks",
        help="list the tracks, or draw one (procedural loops too) and write it as a track file",
        description="List the shipped tracks and the procedural loops' names, or draw a track.",
    )
    actions = tracks.add_subparsers(dest="action", metavar="ACTION", parser_class=type(tracks))
    actions.required = True
    listing = actions.add_parser(
        "list",
        help="the shipped tracks and how procedural loops are named",
        description="Print the shipped tracks (corners, width, perimeter) and the rule naming"
        " procedural loops (random:<split>:<index>).",
    )
    listing.set_defaults(func=run_list)
    show = actions.add_parser(
        "show",
        help="draw a track top-down as a PNG (and --toml: write it as a track file)",
        description="Draw a track top-down with its corners labelled; with --toml also write it"
        " as a track file in driving order, which loads back to the same vertices.",
    )
    show.add_argument(
        "track", help="shipped name, a .toml path, or a procedural loop (random:test:17)"
    )
    show.add_argument("--out", required=True, metavar="FILE", help="PNG to write (replaced)")
    show.add_argument(
        "--toml", metavar="FILE", default=None, help="also write the track file (replaced)"
    )
    show.add_argument("--reverse", action="store_true", help="against the file order")
    show.add_argument(
        "--start-corner", default=None, metavar="LABEL", help="loops: the corner laps start on"
    )
    show.set_defaults(func=run_show)
    return tracks


def track_summary(track: Track) -> str:
    """One line: corners with their turns (left +), width and perimeter."""
    turns = " ".join(f"{c.label} {c.turn_deg:+.0f}°" for c in track.corners) or "no corners"
    kind = "loop" if track.closed else "open"
    return f"{kind}, {turns}; width {track.width_m:g} m, length {track.length_m:.2f} m"


def track_toml(track: Track) -> str:
    """``track`` as the text of a track file, in driving order (reversed tracks as driven)."""
    turns = ", ".join(f"{c.label} {c.turn_deg:+.1f}°" for c in track.corners)
    direction = " (reversed)" if track.reversed else ""
    lines = [
        f"# {track.name}{direction}, written by lfd-track tracks show; vertices in driving order.",
        f"name = {json.dumps(track.name, ensure_ascii=False)}",
        f"description = {json.dumps(f'{turns}; length {track.length_m:.2f} m', ensure_ascii=False)}",
        f"closed = {'true' if track.closed else 'false'}",
        f"width_m = {track.width_m!r}",
        "vertices = [",
        *(f"    [{float(x)!r}, {float(y)!r}]," for x, y in track.vertices),
        "]",
        "",
        "[corners]",
        *(
            f"{json.dumps(c.label, ensure_ascii=False)} = {c.vertex}"
            for c in sorted(track.corners, key=lambda c: c.vertex)
        ),
    ]
    return "\n".join(lines) + "\n"


def run_list(args: argparse.Namespace) -> int:
    """The ``tracks list`` command."""
    print("shipped tracks (by name):")
    for path in sorted(data_dir("tracks").glob("*.toml")):
        try:
            print(f"  {path.stem}: {track_summary(load_track(path))}")
        except LfdTrackError as exc:
            print(f"  {path.stem}: cannot load ({exc})")
    first, last = loop_seed(SPLITS[0], 0), loop_seed(SPLITS[-1], LOOPS_PER_SPLIT - 1)
    d = DEFAULT_LOOPS
    print(
        f"procedural loops: random:<split>:<index>, split one of {', '.join(SPLITS)}, index"
        f" 0..{LOOPS_PER_SPLIT - 1}; loop i of the k-th split is seed k*{LOOPS_PER_SPLIT} + i"
        f" (seeds {first}..{last}); {d.min_corners}-{d.max_corners} corners,"
        f" turns {d.min_turn_deg:g}-{d.max_turn_deg:g}° either way,"
        f" widths {d.min_width_m:g}-{d.max_width_m:g} m (tracks/README.md)"
    )
    print('"random" (or random:<split>) in the env: a new loop of that split every episode')
    return EXIT_OK


def run_show(args: argparse.Namespace) -> int:
    """The ``tracks show`` command."""
    import cv2  # lazy: OpenCV loads only when a picture is written

    from ..render.topdown import draw_topdown
    from ..utils.atomic import atomic_write_bytes, atomic_write_text

    outputs = [Path(args.out), *([Path(args.toml)] if args.toml else [])]
    for out in outputs:
        check_output(out, [("track", args.track)])
    if args.toml and same_file(args.out, args.toml):
        raise LfdTrackError(f"{shown_path(args.toml)}: given as both --out and --toml")
    track = load_track(args.track, reverse=args.reverse, start_corner=args.start_corner)
    ok, png = cv2.imencode(".png", cv2.cvtColor(draw_topdown(track), cv2.COLOR_RGB2BGR))
    if not ok:
        raise OSError(f"{args.out}: PNG encoding failed")
    atomic_write_bytes(args.out, png.tobytes())
    if args.toml:
        atomic_write_text(args.toml, track_toml(track))
    sharpest = max((abs(c.turn_deg) for c in track.corners), default=math.nan)
    print(f"{track.name}: {track_summary(track)}; sharpest turn {sharpest:.0f}°")
    print(f"wrote {shown_path(args.out)}" + (f" and {shown_path(args.toml)}" if args.toml else ""))
    return EXIT_OK
