"""The map rule's fresh-felt map at the failing vertex of sharp loops, drawn and measured.

Drives the map rule exactly as ``../../generalization/rules.py`` does (``RuleController``,
``run_loop_trials``; the map with the paper's constants) on the trials of
``../trials/sharp_corners.toml``, condition ``paper``, for the given repetitions, and keeps, on
loops whose sharpest turn is past 135 deg, a copy of ``FreshFeltMemory``'s arrays (points, felt
levels, path, own-strip links, visited weights, the weights the inputs came from) at every
command within 1.2 m of a corner past 100 deg. Nothing the rover does changes: the library's
``see`` is wrapped, the copy is made after it returned, from its own (pure) helpers.

Then, for every failed lap (its failing corner found as ``../classify.py`` does) and a few
succeeded laps at a corner past 135 deg, the commands around the vertex are measured against the
track's geometry (diagnostic only: the map never sees it) and drawn (world coordinates, 1.8 m
square around the vertex, 400 x 400 px).

    .venv/bin/python benchmarks/experiments/sharp_corners/vertex/vertex_maps.py --repetitions 0 1

Writes ``vertex/png/*.png``, ``vertex/steps.md`` (the numbers of every command drawn or not)
and ``vertex/cache_rep<k>.pkl.gz`` (the copied arrays; ``--no-run`` redraws from them).
"""

from __future__ import annotations

import argparse
import gzip
import importlib.util
import math
import pickle
import sys
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image, ImageDraw

import lfd_track.benchmark.runner as runner
from lfd_track.benchmark.runner import repetition_seeds, repetition_streams
from lfd_track.policy import memory as memory_module
from lfd_track.policy.memory import FreshFeltMemory
from lfd_track.study.spec import load_study
from lfd_track.world.loops import sharpest_turn_deg

HERE = Path(__file__).resolve().parent
SC = HERE.parent
STUDY = SC / "trials" / "sharp_corners.toml"


def _load(name: str, path: Path) -> Any:
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


rules = _load("rules", SC.parent / "generalization" / "rules.py")
classify = _load("classify", SC / "classify.py")

NEAR_M = 1.2  # keep the map's arrays within this of a vertex turning > 100 deg
SHARP_DEG = 135.0
STATE: dict[str, Any] = {"near": False, "snap": None, "laps": [], "keep_success": 6}

# ---------------------------------------------------------------- the map's arrays, copied
_see = FreshFeltMemory.see


def fresh_weights(self: FreshFeltMemory) -> tuple[np.ndarray, ...]:
    """The map's points' distance, ahead and own-strip masks and fresh weights, as ``see``
    weighs them, and which reach it used ("reach", "blank_reach" or "blank")."""
    cfg = self.config
    points = self._points
    dist = np.hypot(points[:, 0], points[:, 1])
    ahead = points[:, 0] > -memory_module.BEHIND_M
    own = self._own_strip(dist) if cfg.strip_link_m else np.ones(len(dist), bool)
    weights = self._fresh(dist < cfg.reach_m, ahead & own)
    used = "reach"
    if weights.sum() < memory_module.MIN_FRESH and cfg.blank_reach_m:
        weights = self._fresh(dist < cfg.blank_reach_m, ahead & own)
        used = "blank_reach"
    if weights.sum() < memory_module.MIN_FRESH:
        used = "blank"
    return dist, ahead, own, weights, used


def step_row(step: Any) -> list[float]:
    """A traced step: pose after, command, the map's three inputs, pose before."""
    before = step.moment.info.get("pose")
    after = step.info_after.get("pose")
    mem = np.asarray(step.percept.memory, dtype=float)[-3:]
    return [*map(float, after[:3]), float(int(step.command)), *map(float, mem),
            *map(float, (before if before is not None else after)[:3])]  # fmt: skip


def see_and_copy(self: FreshFeltMemory, values: np.ndarray, levels: Any = None) -> None:
    _see(self, values, levels)
    STATE["snap"] = None
    if not STATE["near"]:
        return
    points = self._points
    dist, ahead, own, weights, used = fresh_weights(self)
    kept = self._kept(self._felt > 0.0)
    STATE["snap"] = {
        "points": points.astype(np.float32),
        "felt": self._felt.astype(np.float32),
        "path": self._path.astype(np.float32),
        "ahead": ahead,
        "own": own,
        "kept": (np.zeros(len(dist)) if kept is None else kept).astype(np.float32),
        "weights": weights.astype(np.float32),
        "used": used,
        "inputs": self._inputs.copy(),
    }


# ---------------------------------------------------------------- driving, traced
_run_trial = runner.run_trial


def traced_run_trial(env: Any, controller: Any, *, seed: int | None, **kw: Any) -> Any:
    track = env.unwrapped.track if hasattr(env, "unwrapped") else env.track
    sharp = sharpest_turn_deg(track) > SHARP_DEG
    turns = np.degrees(np.abs(track.vertex_turns_rad))
    watch = track.vertices[turns > 100.0]
    steps: list[list[float]] = []
    snaps: dict[int, dict] = {}
    STATE["near"] = False

    def on_loop_step(step: Any) -> None:
        after = step.info_after.get("pose")
        k = len(steps)
        steps.append(step_row(step))
        if STATE["snap"] is not None:
            snaps[k] = STATE["snap"]
        STATE["near"] = bool(
            sharp and len(watch) and np.hypot(*(watch - np.asarray(after[:2])).T).min() < NEAR_M
        )

    info, trajectory, n = _run_trial(env, controller, seed=seed, on_loop_step=on_loop_step, **kw)
    STATE["near"] = False
    lap = {
        "track": track.name,
        "direction": "cw" if track.reversed else "ccw",
        "sharp": sharp,
        "success": bool(info["success"]),
        "failure": info["failure"],
        "corner_order": [c.label for c in track.corners],
        "corners_reached": list(info["corners_reached"]),
        "corners_negotiated": list(info["corners_negotiated"]),
        "steps": steps,
        "snaps": snaps,
    }
    kept_success = sum(1 for x in STATE["laps"] if x["success"] and x["snaps"])
    if lap["success"] and kept_success >= STATE["keep_success"]:
        lap["snaps"] = {}
    if not sharp:
        lap["snaps"] = {}
    STATE["laps"].append(lap)
    return info, trajectory, n


def drive(repetition: int) -> list[dict]:
    study = load_study(STUDY)
    config = next(c for c in study.conditions if c.name == "paper").config
    seed = study.seeds[0]
    repetition_seed = repetition_seeds(seed, repetition + 1)[repetition]
    demo_seed, _, trial_seed = repetition_streams(repetition_seed)
    library = rules.library_of(demo_seed, config.preset)
    controller = rules.RuleController(library, "map-rule")
    STATE["laps"] = []
    outcomes, _ = rules.run_loop_trials(
        controller, trial_seed=trial_seed, config=config, repetition=repetition
    )
    assert len(outcomes) == len(STATE["laps"])
    for o, lap in zip(outcomes, STATE["laps"], strict=True):
        assert o.track == lap["track"] and o.success == lap["success"]
        lap["direction"] = o.direction
        lap["repetition"] = repetition
    return STATE["laps"]


# ---------------------------------------------------------------- geometry (diagnostic only)
def to_world(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.column_stack(
        [
            pose[0] + c * points[:, 0] - s * points[:, 1],
            pose[1] + s * points[:, 0] + c * points[:, 1],
        ]
    )


def corner_frame(track: Any, corner: Any) -> dict:
    verts, i = track.vertices, corner.vertex
    v, prev, nxt = verts[i], verts[i - 1], verts[(i + 1) % len(verts)]
    u_in = (v - prev) / np.linalg.norm(v - prev)
    u_out = (nxt - v) / np.linalg.norm(nxt - v)
    return {
        "v": v, "u_in": u_in, "u_out": u_out, "len_in": float(np.linalg.norm(v - prev)),
        "len_out": float(np.linalg.norm(nxt - v)), "half": track.width_m / 2.0,
        "sign": 1.0 if corner.turn_deg > 0 else -1.0, "turn": corner.turn_deg,
    }  # fmt: skip


def categories(world: np.ndarray, f: dict, track: Any) -> np.ndarray:
    """Each point's place: 0 outgoing strip body, 1 incoming strip body, 2 outgoing strip's
    back-extension only, 3 incoming strip's end extension only, 4 both extensions (the tip),
    5 another strip, 6 carpet."""
    d = world - f["v"]
    n_in = np.array([-f["u_in"][1], f["u_in"][0]])
    n_out = np.array([-f["u_out"][1], f["u_out"][0]])
    s_in, l_in = d @ f["u_in"], d @ n_in
    s_out, l_out = d @ f["u_out"], d @ n_out
    h = f["half"]
    out_body = (s_out >= 0) & (s_out <= f["len_out"]) & (np.abs(l_out) <= h)
    in_body = (s_in <= 0) & (s_in >= -f["len_in"]) & (np.abs(l_in) <= h)
    out_back = (s_out < 0) & (s_out >= -h) & (np.abs(l_out) <= h)
    in_end = (s_in > 0) & (s_in <= h) & (np.abs(l_in) <= h)
    on = track.on_felt(world)
    cat = np.full(len(world), 6)
    cat[on] = 5
    cat[in_end & ~out_back] = 3
    cat[out_back & ~in_end] = 2
    cat[in_end & out_back] = 4
    cat[in_body] = 1
    cat[out_body] = 0
    return cat


CAT_NAMES = ("out body", "in body", "out back-ext", "in end-ext", "tip (both ext)", "other strip",
             "carpet")  # fmt: skip


def measure(lap: dict, k: int, f: dict, track: Any) -> dict:
    steps = np.asarray(lap["steps"])
    pose = steps[k, 7:10]
    snap = lap["snaps"][k]
    world = to_world(snap["points"].astype(float), pose)
    cat = categories(world, f, track)
    w = snap["weights"].astype(float)
    mass = w.sum()
    row: dict[str, Any] = {"k": k, "cmd": int(steps[k, 3]), "used": snap["used"]}
    row["dV"] = float(np.linalg.norm(pose[:2] - f["v"]))
    row["past"] = float((pose[:2] - f["v"]) @ f["u_in"])
    n_in0 = np.array([-f["u_in"][1], f["u_in"][0]])
    row["rover_lat"] = float((pose[:2] - f["v"]) @ n_in0 * f["sign"])  # + inner side
    heading = math.atan2(f["u_in"][1], f["u_in"][0])
    row["heading"] = math.degrees(classify.wrap(pose[2] - heading)) * f["sign"]  # toward turn +
    inputs = snap["inputs"]
    row["amount"] = float(inputs[1])
    row["bearing"] = (2 * float(inputs[0]) - 1) * 30.0 * f["sign"] if inputs[1] > 0 else None
    toward = 1 if f["sign"] > 0 else 2
    row["dir"] = "F" if row["cmd"] == 0 else ("toward" if row["cmd"] == toward else "away")
    row["mass"] = float(mass)
    row["split"] = [float(w[cat == c].sum() / mass) if mass >= 1 else 0.0 for c in range(7)]
    if mass >= 1:
        cw = (w[:, None] * world).sum(0) / mass
        n_in = np.array([-f["u_in"][1], f["u_in"][0]])
        row["centre_lat_in"] = float((cw - f["v"]) @ n_in * f["sign"])  # + inner side
        row["centre_s_in"] = float((cw - f["v"]) @ f["u_in"])
        row["centre"] = cw
    pts = snap["points"].astype(float)

    def bearing_of(wt: np.ndarray) -> float | None:
        m = wt.sum()
        if m < 1.0:
            return None
        cx, cy = (wt * pts[:, 0]).sum() / m, (wt * pts[:, 1]).sum() / m
        return math.degrees(math.atan2(cy, cx)) * f["sign"]

    # the bearing (toward the turn +) without the outgoing strip's back-extension, without any
    # strip extension at the vertex, and with the outgoing strip's body never counted visited
    row["b_no_outback"] = bearing_of(w * ~np.isin(cat, (2, 4)))
    row["b_no_ext"] = bearing_of(w * ~np.isin(cat, (2, 3, 4)))
    reach = np.hypot(pts[:, 0], pts[:, 1]) < (0.6 if snap["used"] == "reach" else 1.0)
    body = (cat == 0) & snap["ahead"] & snap["own"] & reach
    w2 = np.where(body, snap["felt"], w)
    row["b_out_fresh"] = bearing_of(w2)
    # a blank look that also takes felt behind the axle (not only ahead): fresh, linked, 1.0 m
    everywhere = snap["felt"] * snap["own"] * (np.hypot(pts[:, 0], pts[:, 1]) < 1.0)
    row["b_behind"] = bearing_of(everywhere * snap["kept"].astype(float))
    felt = snap["felt"] >= 0.5
    d = world - f["v"]
    s_out = d @ f["u_out"]
    first = felt & (cat == 0) & (s_out <= 1.0)
    row["out_seen"] = int(first.sum())
    row["out_visited"] = float((snap["kept"][first] <= 0).mean()) if first.any() else None
    row["out_ahead"] = float(snap["ahead"][first].mean()) if first.any() else None
    row["out_own"] = float(snap["own"][first].mean()) if first.any() else None
    near = felt & (np.hypot(*snap["points"].T) < 1.2)
    row["registered"] = float(track.on_felt(world[near]).mean()) if near.any() else None
    return row


# ---------------------------------------------------------------- drawing
SIZE, SPAN = 400, 1.8


def draw(lap: dict, k: int, f: dict, track: Any, row: dict, out_png: Path, title: str) -> None:
    steps = np.asarray(lap["steps"])
    pose = steps[k, 7:10]
    snap = lap["snaps"][k]
    scale = SIZE / SPAN
    lo = f["v"] - SPAN / 2

    def px(p: np.ndarray) -> tuple[float, float]:
        return (float((p[0] - lo[0]) * scale), float(SIZE - (p[1] - lo[1]) * scale))

    img = Image.new("RGB", (SIZE, SIZE), (255, 255, 255))
    g = ImageDraw.Draw(img)
    for poly in track.strip_polygons():
        g.polygon([px(p) for p in poly], fill=(236, 232, 214))
    for j, poly in enumerate(track.strip_polygons()):
        start = track.segment_starts[j]
        colour = (150, 150, 150)
        if np.allclose(start, f["v"]):
            colour = (40, 160, 40)  # outgoing strip
        elif np.allclose(track.segment_ends[j], f["v"]):
            colour = (60, 90, 200)  # incoming strip
        g.polygon([px(p) for p in poly], outline=colour)
    world = to_world(snap["points"].astype(float), pose)
    felt = snap["felt"]
    kept = snap["kept"]
    w = snap["weights"]
    for p, fl, kp in zip(world, felt, kept, strict=True):
        x, y = px(p)
        if fl < 0.5:
            shade = int(225 - 60 * fl)
            g.point((x, y), fill=(shade, shade, shade))
        elif kp <= 0:
            g.ellipse((x - 1.5, y - 1.5, x + 1.5, y + 1.5), fill=(120, 120, 200))  # visited felt
        else:
            g.ellipse((x - 1.5, y - 1.5, x + 1.5, y + 1.5), fill=(250, 160, 40))  # fresh felt
    own = snap["own"] & snap["ahead"] & (felt >= 0.5)
    for p in world[own & (kept > 0)]:
        x, y = px(p)
        g.rectangle((x - 2, y - 2, x + 2, y + 2), outline=(230, 120, 0))  # fresh and linked
    for p, wi in zip(world[w > 0], w[w > 0], strict=True):
        x, y = px(p)
        r = 1.5 + 2.5 * float(wi)
        g.ellipse((x - r, y - r, x + r, y + r), fill=(220, 30, 30))  # weighs in the inputs
    path = to_world(snap["path"].astype(float), pose) if len(snap["path"]) else np.zeros((0, 2))
    traj = steps[max(0, k - 40) : k + 1, 7:9]
    g.line([px(p) for p in traj], fill=(0, 0, 0), width=1)
    for p in path:
        x, y = px(p)
        g.ellipse((x - 1, y - 1, x + 1, y + 1), outline=(150, 0, 150))
    # reach circle
    c = px(pose[:2])
    r = 0.6 * scale
    g.ellipse((c[0] - r, c[1] - r, c[0] + r, c[1] + r), outline=(200, 200, 255))
    # rover
    hd = np.array([math.cos(pose[2]), math.sin(pose[2])])
    nm = np.array([-hd[1], hd[0]])
    tri = [pose[:2] + 0.12 * hd, pose[:2] - 0.06 * hd + 0.06 * nm, pose[:2] - 0.06 * hd - 0.06 * nm]
    g.polygon([px(p) for p in tri], outline=(0, 0, 0), fill=(80, 80, 80))
    if "centre" in row:
        cx, cy = px(row["centre"])
        g.line([c, (cx, cy)], fill=(220, 30, 30), width=2)
        g.line((cx - 5, cy - 5, cx + 5, cy + 5), fill=(120, 0, 0), width=2)
        g.line((cx - 5, cy + 5, cx + 5, cy - 5), fill=(120, 0, 0), width=2)
    vx, vy = px(f["v"])
    g.ellipse((vx - 3, vy - 3, vx + 3, vy + 3), outline=(0, 120, 0))
    cmd = "FORWARD" if row["dir"] == "F" else ("LEFT" if row["cmd"] == 1 else "RIGHT")
    bearing = "blank" if row["bearing"] is None else f"{row['bearing']:+.1f}"
    lines = [
        title,
        f"cmd {k}: {cmd} ({row['dir']})  bearing(toward+) {bearing}  {row['used']}",
        f"dV {row['dV']:.2f} m  past V {row['past']:+.2f}  lat {row['rover_lat']:+.2f} (inner+)"
        f"  heading {row['heading']:+.0f} deg (toward+)",
        "fresh: " + " ".join(f"{n.split()[0]}{'-' + n.split()[1][:4] if ' ' in n else ''}"
                             f" {s:.0%}" for n, s in zip(CAT_NAMES, row["split"], strict=True) if s > 0.005),
        f"out strip 1st m: {row['out_seen']} felt pts, visited {fmt(row['out_visited'])},"
        f" ahead {fmt(row['out_ahead'])}",
        f"bearing w/o out back-ext {fmt(row['b_no_outback'], '+.0f')}, w/o ext"
        f" {fmt(row['b_no_ext'], '+.0f')}, out body fresh {fmt(row['b_out_fresh'], '+.0f')}",
    ]  # fmt: skip
    for j, text in enumerate(lines):
        g.text((4, 3 + 11 * j), text.replace("None", "-"), fill=(0, 0, 0))
    g.text((4, SIZE - 14), "blue: in strip, green: out; red: weighs; orange: fresh; slate: visited",
           fill=(90, 90, 90))  # fmt: skip
    img.save(out_png, optimize=True)


PNG = HERE / "png"


# ---------------------------------------------------------------- analysis
def failing_corner(lap: dict, track: Any) -> Any:
    cl = classify.classify_lap({**lap, "steps": [s[:7] for s in lap["steps"]], "corners": [
        [c.label] for c in track.corners]})  # fmt: skip
    return next(c for c in track.corners if c.label == cl["corner"]), cl


def window(lap: dict, f: dict) -> list[int]:
    steps = np.asarray(lap["steps"])
    d = np.linalg.norm(steps[:, 7:9] - f["v"], axis=1)
    close = np.nonzero(d <= classify.CLOSE_M)[0]
    k0 = int(close[0]) if len(close) else int(np.argmin(d))
    ks = [k for k in range(k0 - 4, k0 + 8) if k in lap["snaps"]]
    return ks


def verdict(tag: str, cl: dict, corner: Any, rows: list[dict]) -> str:
    """The decisive command of a failed lap and whether H1 or H2 alone would have changed it."""
    away = [i for i, r in enumerate(rows) if r["dir"] == "away"]
    if not away:
        return (
            f"| {tag} | {cl['cls']} | {corner.label} ({corner.turn_deg:+.0f}) | - | no away pivot |"
        )
    i = away[0]
    kind = "away"
    if rows[i]["bearing"] is None:  # blank: the side came from the last fresh felt
        before = [j for j in range(i) if rows[j]["bearing"] is not None]
        if not before:
            return (
                f"| {tag} | {cl['cls']} | {corner.label} | {rows[i]['k']} | blank, no side seen |"
            )
        i, kind = before[-1], "side"
    r = rows[i]

    def decides_away(b: float | None) -> bool:
        if b is None:
            return kind == "side"  # nothing fresh: the side stays as it was (away)
        return b < -20.0 if kind == "away" else b < 0.0

    h1 = not decides_away(r["b_no_outback"])
    h2 = not decides_away(r["b_out_fresh"])
    return (
        f"| {tag} | {cl['cls']} | {corner.label} ({corner.turn_deg:+.0f}) | {r['k']} | {kind} |"
        f" {r['rover_lat']:+.2f} | {r['heading']:+.0f} | {fmt(r['bearing'], '+.1f')} |"
        f" {fmt(r.get('centre_lat_in'), '+.2f')} | {fmt(r.get('centre_s_in'), '+.2f')} |"
        f" {fmt(r['out_visited'])} | {fmt(r['b_no_outback'], '+.1f')} |"
        f" {fmt(r['b_out_fresh'], '+.1f')} | {'yes' if h1 else 'no'} | {'yes' if h2 else 'no'} |"
    )


def fmt(x: Any, spec: str = ".2f") -> str:
    return "-" if x is None else format(x, spec)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repetitions", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--no-run", action="store_true", help="use the cached arrays")
    parser.add_argument("--png-per-failed", type=int, default=6)
    parser.add_argument("--png-per-success", type=int, default=4)
    parser.add_argument("--successes", type=int, default=2, help="succeeded laps drawn")
    parser.add_argument("--png-reps", type=int, nargs="*", default=None,
                        help="draw only these repetitions' laps (default: all)")  # fmt: skip
    args = parser.parse_args()
    FreshFeltMemory.see = see_and_copy
    runner.run_trial = traced_run_trial
    laps: list[dict] = []
    for rep in args.repetitions:
        cache = HERE / f"cache_rep{rep}.pkl.gz"
        if args.no_run and cache.exists():
            with gzip.open(cache, "rb") as fh:
                got = pickle.load(fh)
        else:
            got = drive(rep)
            got = [lap for lap in got if lap["sharp"]]
            with gzip.open(cache, "wb") as fh:
                pickle.dump(got, fh)
        laps += got
        print(
            f"rep {rep}: {sum(x['success'] for x in got)}/{len(got)} sharp laps lapped", flush=True
        )
    from lfd_track.world.track import loop_track

    PNG.mkdir(exist_ok=True)
    for old in PNG.glob("*.png"):
        old.unlink()
    chosen: list[tuple[dict, Any, dict, bool]] = []
    for lap in laps:
        _, split, index = lap["track"].split(":")
        track = loop_track(split, int(index), reverse=lap["direction"] == "cw")
        lap["_track"] = track
        if not lap["success"]:
            corner, cl = failing_corner(lap, track)
            chosen.append((lap, corner, cl, False))
    failed_turns = [abs(c.turn_deg) for _, c, _, _ in chosen]
    successes = []
    for lap in laps:
        if lap["success"] and lap["snaps"]:
            track = lap["_track"]
            for corner in track.corners:
                ks = window(lap, corner_frame(track, corner))
                if abs(corner.turn_deg) > SHARP_DEG and len(ks) >= 10 and ks[0] >= 10:
                    successes.append((lap, corner, {"cls": "lapped"}, True))
    # contrast: succeeded laps whose sharpest corner is nearest the failed corners' turns
    target = float(np.median(failed_turns)) if failed_turns else 150.0
    successes.sort(key=lambda t: abs(abs(t[1].turn_deg) - target))
    chosen += successes[: args.successes]
    out = ["# Every command around the vertex (vertex_maps.py)", ""]
    verdicts: list[str] = []
    head = ("| lap | k | dV | past V | rover lat (inner +) | heading | cmd | bearing | used | mass | "
            + " | ".join(CAT_NAMES) + " | out 1st m seen/visited/ahead/own | registered | b w/o out back-ext | b w/o ext |"
            " b if out body fresh | centre lat (inner +) | centre past V | b blank look behind too |")  # fmt: skip
    for lap, corner, cl, ok in chosen:
        track = lap["_track"]
        f = corner_frame(track, corner)
        tag = (f"r{lap['repetition']}_{lap['track'].split(':')[-1]}_{lap['direction']}"
               f"_c{corner.label}")  # fmt: skip
        ks = window(lap, f)
        rows = [measure(lap, k, f, track) for k in ks]
        out += [
            f"## {tag}: {'lapped' if ok else lap['failure']} ({cl['cls']}), corner {corner.label}"
            f" {corner.turn_deg:+.1f} deg, width {track.width_m:.3f} m",
            "",
            head,
            "|" + "---|" * (head.count("|") - 1),
        ]
        for r in rows:
            out.append(
                f"| {tag} | {r['k']} | {r['dV']:.2f} | {r['past']:+.2f} | {r['rover_lat']:+.2f} |"
                f" {r['heading']:+.0f} |"
                f" {r['dir']} | {fmt(r['bearing'], '+.1f')} | {r['used']} | {r['mass']:.1f} | "
                + " | ".join(f"{s:.0%}" for s in r["split"])
                + f" | {r['out_seen']}/{fmt(r['out_visited'])}/{fmt(r['out_ahead'])}"
                f"/{fmt(r['out_own'])} | {fmt(r['registered'])} | {fmt(r['b_no_outback'], '+.1f')} |"
                f" {fmt(r['b_no_ext'], '+.1f')} | {fmt(r['b_out_fresh'], '+.1f')} |"
                f" {fmt(r.get('centre_lat_in'))} | {fmt(r.get('centre_s_in'))} |"
                f" {fmt(r['b_behind'], '+.1f')} |"
            )
        out.append("")
        if not ok:
            verdicts.append(verdict(tag, cl, corner, rows))
        # the PNGs: around the first pivot of the window (the decisive one)
        n = args.png_per_success if ok else args.png_per_failed
        if args.png_reps is not None and lap["repetition"] not in args.png_reps:
            n = 0
        pivots = [i for i, r in enumerate(rows) if r["dir"] != "F"]
        centre = pivots[0] if pivots else len(rows) // 2
        lo = max(0, min(centre - n // 2, len(rows) - n))
        for r in rows[lo : lo + n] if n else []:
            draw(lap, r["k"], f, track, r, PNG / f"{tag}_k{r['k']:03d}.png",
                 f"{tag} {'LAPPED' if ok else cl['cls']}")  # fmt: skip
    out[2:2] = [
        "## The decisive command of each failed lap",
        "",
        "The first pivot away from the turn near the vertex (`away`), or, when it was chosen on a"
        " blank map, the last command with fresh felt before it (`side`: it set the side the rule"
        " pivots to while blank). Bearings toward the turn positive [deg]; what the rule would"
        " have done without the outgoing strip's back-extension (H1), or with the outgoing strip's"
        " body never counted visited (H2). Lateral offsets from the incoming centreline [m], inner"
        " side positive.",
        "",
        "| lap | class | corner | k | kind | rover lat | heading | bearing | centre lat | centre"
        " past V | out 1st m visited | w/o out back-ext | out body fresh | H1 flips | H2 flips |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
        *verdicts,
        "",
    ]
    (HERE / "steps.md").write_text("\n".join(out) + "\n", encoding="utf-8")
    print(f"{len(chosen)} laps, {len(list(PNG.glob('*.png')))} PNGs", flush=True)


if __name__ == "__main__":
    main()
