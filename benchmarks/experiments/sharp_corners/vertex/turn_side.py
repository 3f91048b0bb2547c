"""Can the map's own arrays tell the side a sharp corner turns, as the rover arrives near it?

Reads ``vertex/turnside_rep<k>.pkl.gz`` (written by ``turn_side_record.py``: the fresh-felt
map's points, felt levels, fresh weights and path at every command of every lap, condition
``paper``). Every estimator below uses only those arrays and the map's three inputs (what the
robot has); the track geometry is used only to score (the true side of a corner, where the
rover is).

    .venv/bin/python benchmarks/experiments/sharp_corners/vertex/turn_side.py

Writes ``vertex/turn_side_tables.md`` (the tables ``turn_side.md`` quotes). Signs: + = left.
"""

from __future__ import annotations

import gzip
import math
import pickle
from pathlib import Path

import numpy as np

from lfd_track.world.track import loop_track

HERE = Path(__file__).resolve().parent
REPS = range(6)
SHARP = 100.0
CLOSE = 0.3
BEFORE = (0.0, 0.3, 0.6)  # driven metres before the arrival command
RANGE_DEG = 30.0  # the map's bearing_range_deg (paper map)
FULL_FRESH = 20.0


# ------------------------------------------------------------------ the map's own quantities
def path_frame(path: np.ndarray, back_m: float) -> np.ndarray | None:
    """Unit vector of the rover's direction of travel over its last ``back_m`` of path (rover
    frame; from the oldest path place within that arc length to the axle), None if the path
    spans less than 0.15 m there (pivoting in place since the start)."""
    full = np.vstack([path, np.zeros((1, 2))])[::-1]  # newest first, axle first
    seg = np.hypot(*np.diff(full, axis=0).T)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    idx = int(np.nonzero(arc <= back_m + 1e-9)[0][-1])
    p = full[idx]
    n = math.hypot(*p)
    if n < 0.15:
        return None
    return -p / n


def in_frame(points: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(along, lateral-left) of ``points`` in the path's frame through the axle."""
    n = np.array([-u[1], u[0]])
    return points @ u, points @ n


def centreline(
    s: np.ndarray, lat: np.ndarray, felt: np.ndarray, lo: float, hi: float
) -> float | None:
    """Felt-weighted mean lateral of felt (>= 0.5) abeam of the path stretch s in [lo, hi],
    within 0.5 m of the path line."""
    m = (felt >= 0.5) & (s >= lo) & (s <= hi) & (np.abs(lat) < 0.5)
    if felt[m].sum() < 3.0:
        return None
    return float((felt[m] * lat[m]).sum() / felt[m].sum())


def sgn(x: float | None, dead: float = 0.0) -> int:
    if x is None or not np.isfinite(x) or abs(x) <= dead:
        return 0
    return 1 if x > 0 else -1


def features(snap: dict, mem: np.ndarray) -> dict:
    """Per-command quantities from one map (rover frame)."""
    pts = snap["points"].astype(float)
    felt = snap["felt"].astype(float)
    w = snap["weights"].astype(float)
    out: dict = {"amount": float(mem[1])}
    out["b"] = (2 * float(mem[0]) - 1) * RANGE_DEG if mem[1] > 0 else None  # E1 bearing [deg]
    mass = w.sum()
    u = path_frame(snap["path"].astype(float), 0.5)
    u8 = path_frame(snap["path"].astype(float), 0.8)
    out["has_frame"] = u is not None
    for tag, uu, lo, hi in (("", u, -0.5, 0.0), ("skip", u8, -0.8, -0.3)):
        if uu is None:
            out[f"c{tag}"] = None
            continue
        s, lat = in_frame(pts, uu)
        c = centreline(s, lat, felt, lo, hi)
        out[f"c{tag}"] = c
        if tag == "":
            out["s"], out["lat"] = s, lat
        if c is not None and mass >= 1.0:
            fl = float((w * lat).sum() / mass)
            out[f"e2{tag}"] = fl - c
    if u is not None:
        s, lat = out["s"], out["lat"]
        big = felt >= 0.5
        c = out["c"] if out["c"] is not None else 0.0
        for tag, ref in (("path", 0.0), ("centre", c)):
            for wtag, lo, hi in (("behind", -1.0, 0.3), ("ahead", 0.0, 1.2)):
                d = lat - ref
                win = big & (s >= lo) & (s <= hi)
                left = felt[win & (d >= 0.25) & (d <= 0.8)].sum()
                right = felt[win & (d <= -0.25) & (d >= -0.8)].sum()
                out[f"e3_{tag}_{wtag}"] = float(left - right)
        # E5 per frame: felt ahead beyond the strip's extent (|lat - c| > 0.3), 1.2 m ahead
        d = lat - c
        win = big & (s > 0.0) & (s <= 1.2) & (np.abs(d) > 0.3) & (np.abs(d) < 1.0)
        out["e5f"] = float((felt[win] * np.sign(d[win])).sum())
        win = big & (s > 0.0) & (s <= 1.2) & (np.abs(d) > 0.4) & (np.abs(d) < 1.0)
        out["e5f40"] = float((felt[win] * np.sign(d[win])).sum())
        # E6 edge bulge: how far the felt's left / right edges (90th / 10th percentile of
        # lateral) move out from a slice 0.6-1.2 m behind to the slice around the axle
        edges = []
        for lo, hi in ((-1.2, -0.6), (-0.4, 0.4)):
            m = big & (s >= lo) & (s <= hi) & (np.abs(lat) < 1.0)
            edges.append(
                None if m.sum() < 5 else (np.percentile(lat[m], 90), np.percentile(lat[m], 10))
            )
        if edges[0] is not None and edges[1] is not None:
            out["e6"] = float((edges[1][0] - edges[0][0]) - (edges[0][1] - edges[1][1]))
    return out


# ------------------------------------------------------------------ estimators
def estimators(feat: list[dict], steps: np.ndarray, cum: np.ndarray, k: int) -> dict[str, int]:
    f = feat[k]
    est: dict[str, int] = {}
    est["E1 bearing now"] = sgn(f["b"])
    # the side the rule holds (its last nonzero bearing, kept while blank)
    side = 0
    for j in range(k, -1, -1):
        if feat[j] and feat[j]["b"] not in (None, 0.0):
            side = sgn(feat[j]["b"])
            break
    est["E1s rule's held side"] = side
    est["E2 fresh vs centreline (0.5 m)"] = sgn(f.get("e2"))
    est["E2 +-0.03 m deadband"] = sgn(f.get("e2"), 0.03)
    est["E2b centreline 0.3-0.8 m back"] = sgn(f.get("e2skip"))
    for tag in ("path", "centre"):
        for wtag in ("behind", "ahead"):
            est[f"E3 all felt {wtag} (lat re {tag})"] = sgn(f.get(f"e3_{tag}_{wtag}"), 1.0)
    for kk in (5, 10):
        num = den = 0.0
        for j in range(max(0, k - kk + 1), k + 1):
            g = feat[j]
            if g and g["b"] is not None:
                num += g["amount"] * g["b"]
                den += g["amount"]
        est[f"E4 mean bearing last {kk}"] = sgn(num / den if den > 0 else None)
    last10 = 0
    for j in range(k, -1, -1):
        if feat[j] and feat[j]["b"] is not None and abs(feat[j]["b"]) > 10.0:
            last10 = sgn(feat[j]["b"])
            break
    est["E4c last |bearing|>10"] = last10

    # E5: branch-off felt over the frames of the last 1 m of driving (sum of signed masses)
    def e5(key: str, metres: float) -> float | None:
        tot, got = 0.0, False
        for j in range(k, -1, -1):
            if cum[k] - cum[j] > metres:
                break
            if feat[j] and key in feat[j]:
                tot += feat[j][key]
                got = True
        return tot if got else None

    e5_1 = e5("e5f", 1.0)
    est["E5 branch felt ahead, last 1 m"] = sgn(e5_1, 2.0)
    est["E5 ... deadband 10"] = sgn(e5_1, 10.0)
    est["E5 ... last 1.5 m"] = sgn(e5("e5f", 1.5), 2.0)
    est["E5 ... beyond 0.4 m"] = sgn(e5("e5f40", 1.0), 2.0)
    est["E5 else E4-10"] = est["E5 branch felt ahead, last 1 m"] or est["E4 mean bearing last 10"]
    est["E6 edge bulge (0.05 m)"] = sgn(f.get("e6"), 0.05)
    est["E5now branch felt ahead, this map"] = sgn(f.get("e5f"), 2.0)
    return est


# ------------------------------------------------------------------ scoring
def load() -> list[dict]:
    laps = []
    for rep in REPS:
        p = HERE / f"turnside_rep{rep}.pkl.gz"
        if p.exists():
            with gzip.open(p, "rb") as fh:
                laps += pickle.load(fh)
    return laps


def main() -> None:
    laps = load()
    corner_rows = []  # (name, moment, est dict, truth, turn, lapped, failing)
    ordinary = []  # (kind, est, amount, truth or 0)
    for lap in laps:
        _, split, index = lap["track"].split(":")
        track = loop_track(split, int(index), reverse=lap["direction"] == "cw")
        steps = lap["steps"]
        pos = steps[:, 7:9]
        # driven distance as the robot knows it: 0.1 m per forward command executed before k
        cum = 0.1 * np.concatenate([[0.0], np.cumsum(steps[:-1, 3] == 0)])
        feat = [features(lap["snaps"][k], steps[k, 4:7]) if k in lap["snaps"] else None
                for k in range(len(steps))]  # fmt: skip
        turns = np.degrees(track.vertex_turns_rad)
        verts = track.vertices
        dall = np.linalg.norm(pos[:, None, :] - verts[None], axis=2)  # (K, V)
        sharp_v = np.abs(turns) > SHARP
        for corner in track.corners:
            if abs(corner.turn_deg) <= SHARP:
                continue
            d = dall[:, corner.vertex]
            close = np.nonzero(d <= CLOSE)[0]
            if not len(close):
                continue
            k0 = int(close[0])
            for before in BEFORE:
                ks = [k for k in range(k0 + 1) if cum[k0] - cum[k] >= before - 1e-6]
                k = ks[-1] if ks else 0
                if feat[k] is None:
                    continue
                corner_rows.append({
                    "name": f"r{lap['repetition']}_{index}_{lap['direction']}_c{corner.label}",
                    "before": before, "est": estimators(feat, steps, cum, k),
                    "truth": 1 if corner.turn_deg > 0 else -1, "turn": abs(corner.turn_deg),
                    "lapped": lap["success"], "amount": feat[k]["amount"], "dV": float(d[k]),
                })  # fmt: skip
        # ordinary driving: > 1.2 m from every vertex turning > 100 deg
        far = (dall[:, sharp_v].min(axis=1) > 1.2) if sharp_v.any() else np.ones(len(pos), bool)
        nearest = dall.argmin(axis=1)
        for k in np.nonzero(far)[0]:
            if feat[k] is None or k < 10:
                continue
            v = nearest[k]
            if dall[k, v] > 0.6:
                kind, truth = "straight (> 0.6 m from a vertex)", 0
            elif abs(turns[v]) < 15:
                continue
            else:
                kind, truth = "gentle corner (<= 100 deg, within 0.6 m)", 1 if turns[v] > 0 else -1
            ordinary.append((kind, estimators(feat, steps, cum, int(k)), feat[k]["amount"], truth))
    write(corner_rows, ordinary)


def write(rows: list[dict], ordinary: list) -> None:
    names = list(rows[0]["est"])
    out = ["# turn_side.py tables", ""]
    for title, sel in (
        ("all corners > 100 deg reached", lambda r: True),
        ("corners > 135 deg", lambda r: r["turn"] > 135),
        ("corners 100-135 deg", lambda r: r["turn"] <= 135),
        ("corners > 100 deg of failed laps", lambda r: not r["lapped"]),
    ):
        sub = [r for r in rows if sel(r)]
        n = {b: sum(1 for r in sub if r["before"] == b) for b in BEFORE}
        out += [f"## {title} (corners: arrival {n[0.0]}, 0.3 m before {n[0.3]}, 0.6 m before {n[0.6]})",
                "", "accuracy = right / all (right / given; abstained)", "",
                "| estimator | arrival | 0.3 m before | 0.6 m before |", "|---|---|---|---|"]  # fmt: skip
        for name in names:
            cells = []
            for b in BEFORE:
                s = [r for r in sub if r["before"] == b]
                if not s:
                    cells.append("-")
                    continue
                e = np.array([r["est"][name] for r in s])
                t = np.array([r["truth"] for r in s])
                right, given = int((e == t).sum()), int((e != 0).sum())
                cells.append(f"{right / len(s):.2f} ({right}/{given}; abst {len(s) - given})")
            out.append(f"| {name} | " + " | ".join(cells) + " |")
        out.append("")
    # blank or small fresh amount at the moment
    for b in BEFORE:
        s = [r for r in rows if r["before"] == b]
        out.append(f"- {b} m before: map blank in {sum(r['amount'] == 0 for r in s)}/{len(s)},"
                   f" amount < 0.25 (mass < 5) in {sum(r['amount'] < 0.25 for r in s)}/{len(s)}")  # fmt: skip
    out += ["", "## ordinary driving (> 1.2 m from any vertex turning > 100 deg)", "",
            "given = gives a side; 'agrees' = same sign as the rule's held side (E1s); at gentle"
            " corners also right = the corner's side", "",
            "| estimator | kind | commands | given | right (gentle) | blank: n / given / differs from held side (/ right, held right) | amount < 0.25: same |",
            "|---|---|---|---|---|---|---|"]  # fmt: skip
    for name in names:
        for kind in sorted({o[0] for o in ordinary}):
            s = [o for o in ordinary if o[0] == kind]
            e = np.array([o[1][name] for o in s])
            held = np.array([o[1]["E1s rule's held side"] for o in s])
            amt = np.array([o[2] for o in s])
            t = np.array([o[3] for o in s])
            given = (e != 0).mean()
            right = f"{(e == t).mean():.2f}" if t.any() else "-"
            cells = []
            for m in (amt == 0, amt < 0.25):
                if m.sum() == 0:
                    cells.append("0")
                    continue
                g = e[m] != 0
                cell = f"{m.sum()} / {g.mean():.2f} / {((e[m] != held[m]) & g).mean():.2f}"
                if t.any():
                    cell += f" / right {(e[m] == t[m]).mean():.2f} vs held {(held[m] == t[m]).mean():.2f}"
                cells.append(cell)
            out.append(
                f"| {name} | {kind} | {len(s)} | {given:.2f} | {right} | {cells[0]} | {cells[1]} |"
            )
    # per-corner detail of failed laps at arrival
    out += ["", "## failed laps' corners, per estimator at arrival (+ left)", ""]
    fail = [r for r in rows if not r["lapped"] and r["before"] == 0.0]
    out.append(
        "| corner | turn | truth | amount | "
        + " | ".join(n.split()[0] + " " + n.split()[1] for n in names)
        + " |"
    )
    out.append("|---" * (4 + len(names)) + "|")
    for r in fail:
        out.append(f"| {r['name']} | {r['turn']:.0f} | {r['truth']:+d} | {r['amount']:.2f} | "
                   + " | ".join(f"{r['est'][n]:+d}" for n in names) + " |")  # fmt: skip
    (HERE / "turn_side_tables.md").write_text("\n".join(out) + "\n", encoding="utf-8")
    print("\n".join(out))


if __name__ == "__main__":
    main()
