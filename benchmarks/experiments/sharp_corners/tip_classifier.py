"""A tip classifier taught by the simulator's track (part 28 of ``README.md``).

Part 27 measured that a sharp corner's tip binds the every-room bar for the map rule and the
learner alike: the felt the map counts fresh although the track puts it 0.3 m or more behind the
rover (part 12's oracle, ``oracle_visited.py --combine cover --cover-from 0.3``). Parts 13-17's
hand-made tests of it either fixed few of the commands the oracle changes or changed 40-70 times
as many others. Here a small network learns the oracle's cover from what the map holds at each
of its fresh felt points (:func:`features`: where it lies, its felt and freshness, its links to
the rover's own strip, the carpet beyond it, the rover's path and the branch side), with the
simulator's track as its teacher, on drives it is never scored on; the robot then runs it without
the track.

* ``collect --data DIR <rules.py arguments>``: drives the map rule on the map as it is
  (``../generalization/rules.py``, its arguments passed on) and records, at each of the map's
  fresh-felt decisions, every fresh point's features and whether the track puts it 0.3 m or more
  behind the rover (per worker process, ``DIR/points_<pid>.pkl``).
* ``fit --data DIR --model FILE``: fits the network (:data:`HIDDEN` tanh units, a logistic
  output; full-batch Adam, :data:`EPOCHS` epochs, seed 0) to the recorded points (every one the
  track puts behind, a fifth of the others), each weighing its share of its decision's fresh
  felt, and writes it as JSON; ``report --data DIR --model FILE`` scores a fitted one on points.
* ``screen --model FILE --thresholds a,b --screen OUT <rules.py arguments>``: ``screen.py``'s
  screen of the tests ``tipnet_<t>``, each leaving out the fresh points the network scores at
  ``t`` or more.
* ``drive --model FILE --threshold T <rules.py arguments>``: the map rule on the map with
  ``tipnet_<T>`` (a rule run).
* Part 29: ``fit-decisions`` fits the network to each decision as a whole
  (:data:`DECISION_FEATURES`, labelled by :func:`oracle_changes`); a decision model's test leaves
  out all of a decision's fresh felt. Part 30: ``collect-commands`` records each frame's decision
  with whether the oracle changes the command there (:class:`CommandMemory`), ``fit-commands``
  fits to that, ``cross-rooms`` fits on one worker's rooms and scores on the other's. Part 33:
  ``screen``/``drive --gate NAME`` leave out only what ``screen.py``'s test NAME and the
  network both leave out.

    .venv/bin/python benchmarks/experiments/sharp_corners/tip_classifier.py collect --data /tmp/tip_classifier/data --study benchmarks/experiments/sharp_corners/trials/tip_train.toml --condition rooms.round20+visual+balance --rule map-rule --map branch_side=true --map branch_window=commands --map motion=visual --map colour_balance=safe_box --map fresh_sight_m=0.05 --out /tmp/tip_classifier/rules_train --workers 2
"""

from __future__ import annotations

import copy
import json
import math
import os
import pickle
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import dead_ends  # noqa: E402
import oracle_visited  # noqa: E402
import screen  # noqa: E402

from lfd_track.policy.memory import MAP_FRAMES, FreshFeltMemory  # noqa: E402

#: [m] part 12's oracle: felt whose centreline lies this far or more behind the rover is covered
COVER_FROM_M = 0.3
#: the network: this many tanh units; full-batch Adam for ``EPOCHS`` epochs at ``RATE``, L2
#: ``DECAY``, starting weights from ``SEED``
HIDDEN, EPOCHS, RATE, DECAY, SEED = 16, 3000, 0.01, 1e-4, 0
#: the fit keeps every point the track puts behind and this share of the others (drawn with
#: ``SEED``), each kept one weighing one over it
NEGATIVE_KEEP = 0.2
#: [m] the felt and fresh felt around a point are counted within this radius
AROUND_M = 0.15
FEATURES = (
    "x",
    "y toward the side",
    "distance",
    "bearing toward the side",
    "felt",
    "freshness",
    "share of the fresh felt",
    "links from the own strip",
    "frame age",
    "carpet beyond",
    "points beyond",
    "felt around",
    "fresh around",
    "from the path",
    "along the new leg",
    "across the new leg toward the side",
    "side known",
    "own strip ends",
    "felt beside",
    "fresh mass",
    "fresh bearing toward the side",
    "bearing off the fresh bearing",
    "leg turned",
)
DATA: dict[str, Path | None] = {"dir": None}
#: the last decision the network scored (its points, weights and newest map point) and its scores
SCORED: dict[str, Any] = {}


def features(memory: FreshFeltMemory, chosen: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(K, len(FEATURES)) float64: what ``memory``'s map holds at its fresh felt points
    ``chosen`` (K,) int, whose fresh weights are ``weights`` (N,) — all of it a robot has."""
    points, felt = memory._points, memory._felt
    sign = screen.side_sign(memory)
    known = memory._side != 0.5
    x, y = points[chosen, 0], points[chosen, 1] * sign
    dist = np.hypot(points[:, 0], points[:, 1])
    mass = float(weights.sum())
    cx = float((weights * points[:, 0]).sum()) / mass
    cy = float((weights * points[:, 1]).sum()) / mass * sign
    fresh_bearing = math.atan2(cy, cx)
    bearing = np.arctan2(y, x)
    hops = memory._strip_hops(dist)[chosen]
    age = (len(points) - 1 - chosen) // 40 / MAP_FRAMES
    gap = points[chosen, None, :] - points[None, :, :]
    near = np.einsum("kni,kni->kn", gap, gap) <= AROUND_M**2
    felt_around = (near * felt[None, :]).sum(axis=1) / np.maximum(near.sum(axis=1), 1)
    fresh_around = (near * (weights > 0.0)[None, :]).sum(axis=1) / 40.0
    path = memory._path
    if len(path):
        to_path = points[chosen, None, :] - path[None, :, :]
        from_path = np.sqrt(np.einsum("kmi,kmi->km", to_path, to_path).min(axis=1))
    else:
        from_path = np.ones(len(chosen))
    found = screen.places_back(path, (screen.NEW_LEG_M, *screen.OLD_LEG_M)) if len(path) else None
    along = np.zeros(len(chosen))
    across = np.zeros(len(chosen))
    turned = 0.0
    if found is not None and np.linalg.norm(found[0]) > 0.0:
        new = -found[0] / np.linalg.norm(found[0])
        along = points[chosen] @ new
        across = (new[0] * points[chosen, 1] - new[1] * points[chosen, 0]) * sign
        old = found[1] - found[2]
        if np.linalg.norm(old) > 0.0:
            turned = 1.0 - float(new @ old) / float(np.linalg.norm(old))
    end = dead_ends.strip_end_m(points, felt, 0.8)
    beside = screen.felt_beside(memory, 0.3, 0.7) if known else False
    seen, level = dead_ends.beyond(points, np.asarray(felt), np.asarray(chosen))
    k = len(chosen)
    return np.column_stack(
        [
            x,
            y,
            dist[chosen],
            bearing,
            felt[chosen],
            weights[chosen] / np.maximum(felt[chosen], 1e-9),
            weights[chosen] / mass,
            np.where(hops < 0, 6.0, hops) / 6.0,
            age,
            np.where(seen > 0, level, 1.0),
            seen / 40.0,
            felt_around,
            fresh_around,
            np.minimum(from_path, 1.0),
            along,
            across,
            np.full(k, float(known)),
            np.full(k, 1.0 if end is None else end),
            np.full(k, float(beside)),
            np.full(k, min(mass / 20.0, 2.0)),
            np.full(k, fresh_bearing),
            bearing - fresh_bearing,
            np.full(k, turned),
        ]
    )


def append(kind: str, record: dict[str, Any]) -> None:
    """Pickle ``record`` onto this worker process's file of ``kind`` records in ``--data``."""
    folder = DATA["dir"]
    assert folder is not None
    with open(folder / f"{kind}_{os.getpid()}.pkl", "ab") as out:
        pickle.dump(record, out)


class CollectMemory(FreshFeltMemory):
    """The map as it is, recording each fresh-felt decision's points, their features and the
    track's word on them."""

    def _fresh(self, near: np.ndarray, ahead: np.ndarray) -> np.ndarray:
        weights = super()._fresh(near, ahead)
        now = oracle_visited.NOW
        chosen = np.flatnonzero(weights > 0.0)
        if now["track"] is None or not len(chosen):
            return weights
        floor = oracle_visited.to_floor(self._points[chosen], now["pose"])
        ahead_now = oracle_visited.track_ahead(now["track"], floor, now["progress_m"], COVER_FROM_M)
        record = {
            "features": features(self, chosen, weights).astype(np.float32),
            "behind": ~ahead_now,
            "share": (weights[chosen] / float(weights.sum())).astype(np.float32),
        }
        append("points", record)
        return weights


#: part 32: the true felt in a fan either side of the rover (an oracle sensor): sectors of
#: ``SIDE_SECTORS_DEG`` off the heading, in bands of ``SIDE_BANDS_M`` from the axle, each read at
#: every 10 degrees and 0.05 m within it
SIDE_SECTORS_DEG = ((30.0, 70.0), (70.0, 110.0), (110.0, 150.0))
SIDE_BANDS_M = ((0.2, 0.45), (0.5, 0.8))
SIDE = {"look": False}


def side_look(track: Any, pose: tuple[float, float, float], sign: float) -> np.ndarray:
    """(12,): the share of felt (by the track) in each sector and band on the branch side's side
    (``sign`` +1: left), then on the other side."""
    out = []
    for side in (sign, -sign):
        for low, high in SIDE_SECTORS_DEG:
            for near, far in SIDE_BANDS_M:
                angles = np.radians(np.arange(low, high + 1e-9, 10.0)) * side
                radii = np.arange(near, far + 1e-9, 0.05)
                a, r = np.meshgrid(angles, radii)
                local = np.column_stack([(r * np.cos(a)).ravel(), (r * np.sin(a)).ravel()])
                floor = oracle_visited.to_floor(local, pose)
                out.append(float(np.mean(track.on_felt(floor))))
    return np.array(out)


class CommandMemory(screen.ScreenMemory):
    """The map as it is (part 30), recording at each frame its first fresh-felt decision's
    features and whether part 12's oracle changes the map rule's command there, as
    ``screen.py`` reads the command (a copy of the map sees the frame with the oracle)."""

    _decision: np.ndarray | None = None

    def _fresh(self, near: np.ndarray, ahead: np.ndarray) -> np.ndarray:
        weights = super()._fresh(near, ahead)
        chosen = np.flatnonzero(weights > 0.0)
        if self._test is None and self._decision is None and len(chosen):
            self._decision = one_decision(self, chosen, weights)
            now = oracle_visited.NOW
            if SIDE["look"] and now["track"] is not None:
                side = side_look(now["track"], now["pose"], screen.side_sign(self))
                self._decision = np.concatenate([self._decision, side])
        return weights

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        if self._test is not None:  # the oracle's copy
            super().see(values, levels)
            return
        twin = copy.copy(self)
        twin._test = "oracle"
        twin.see(values, levels)
        range_deg = self.config.bearing_range_deg
        oracle = screen.command(twin.inputs(), range_deg)
        self._decision = None
        oracle_visited.TrackVisitedMemory.see(self, values, levels)
        if self._decision is None:  # no fresh felt at all: nothing to judge
            return
        as_is = screen.command(self.inputs(), range_deg)
        record = {"features": self._decision.astype(np.float32), "changes": as_is != oracle}
        append("decisions", record)


def records(folder: Path, parts: str) -> Iterator[dict[str, Any]]:
    """The records pickled one after another into ``folder``'s files matching ``parts``."""
    for part in sorted(folder.glob(parts)):
        with open(part, "rb") as f:
            while True:
                try:
                    yield pickle.load(f)
                except EOFError:
                    break


def load_decisions(folder: Path, parts: str = "decisions_*.pkl") -> tuple[np.ndarray, np.ndarray]:
    """Part 30's records of ``folder`` (its files matching ``parts``): decision features
    (D, len(DECISION_FEATURES)) and whether the oracle changes each decision's command (D,)
    bool."""
    xs, ys = [], []
    for record in records(folder, parts):
        xs.append(record["features"])
        ys.append(record["changes"])
    if not xs:
        raise SystemExit(f"{folder}: no recorded decisions")
    return np.vstack(xs).astype(np.float64), np.array(ys, dtype=bool)


def cross_rooms(folder: Path, threshold: float = 0.3, columns: int | None = None) -> None:
    """Part 30's check of what limits the decision network (exploratory, teaching records
    only): fitted on one worker's records (all of them, then their first half) and scored on
    the other's. Each job runs in one worker, so the two hold different rooms. ``columns``: fit
    on the first that many features only (part 32: without the side look)."""
    files = sorted(p.name for p in folder.glob("decisions_*.pkl"))
    if len(files) != 2:
        raise SystemExit(f"{folder}: cross-rooms needs the records of exactly two workers")
    for taught, scored in (files, files[::-1]):
        x, y = load_decisions(folder, taught)
        x_other, y_other = load_decisions(folder, scored)
        x, x_other = x[:, :columns], x_other[:, :columns]
        for share, n in (("all", len(y)), ("first half", len(y) // 2)):
            model = fit(x[:n], y[:n], np.ones(n), negative_keep=1.0)
            blank = TipNet(model).score(x_other) >= threshold
            print(
                f"taught on {share} of {taught} ({int(y[:n].sum())} changed), scored on {scored}:"
                f" blanks {int(blank[y_other].sum())} of the {int(y_other.sum())} decisions the"
                f" oracle changes, {int(blank[~y_other].sum())} of the other {int((~y_other).sum())}"
            )


def load_points(folder: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The recorded points of ``folder``: features (P, F), behind (P,) bool, share (P,) and
    where each decision's points start (D,) int (a decision's points are consecutive)."""
    xs, ys, ws = [], [], []
    for record in records(folder, "points_*.pkl"):
        xs.append(record["features"])
        ys.append(record["behind"])
        ws.append(record["share"])
    if not xs:
        raise SystemExit(f"{folder}: no recorded points")
    starts = np.concatenate([[0], np.cumsum([len(y) for y in ys])[:-1]])
    return (
        np.vstack(xs).astype(np.float64),
        np.concatenate(ys),
        np.concatenate(ws).astype(np.float64),
        starts,
    )


#: part 29: a decision's features are its points' features weighed by their shares, the least
#: and most of :data:`SPREAD` among them, and how many points it has (log)
SPREAD = ("x", "y toward the side", "distance", "from the path", "along the new leg")
DECISION_FEATURES = (
    *(f"mean {name}" for name in FEATURES),
    *(f"least {name}" for name in SPREAD),
    *(f"most {name}" for name in SPREAD),
    "points (log)",
)


def decision_features(x: np.ndarray, share: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """(D, len(DECISION_FEATURES)): the decisions' features from their points' features
    ``x`` (P, F) and shares ``share`` (P,) (summing to 1 in each decision), the decisions'
    points starting at ``starts`` (D,)."""
    spread = x[:, [FEATURES.index(name) for name in SPREAD]]
    counts = np.diff(np.append(starts, len(x)))
    return np.column_stack(
        [
            np.add.reduceat(x * share[:, None], starts, axis=0),
            np.minimum.reduceat(spread, starts, axis=0),
            np.maximum.reduceat(spread, starts, axis=0),
            np.log(counts),
        ]
    )


def one_decision(memory: FreshFeltMemory, chosen: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(len(DECISION_FEATURES),): the features of ``memory``'s decision on its fresh felt points
    ``chosen`` weighing ``weights`` (N,)."""
    share = weights[chosen] / float(weights[chosen].sum())
    points = features(memory, chosen, weights)
    return decision_features(points, share, np.zeros(1, dtype=np.int64))[0]


def side_command(x: np.ndarray, y: np.ndarray, weights: np.ndarray) -> str:
    """The map rule's command on fresh felt at ``x``, ``y`` (toward the branch side) weighing
    ``weights``: ``T`` (pivot toward the side), ``A`` (away), ``F`` or ``B`` (none left, blank).
    """
    if float(weights.sum()) <= 1e-9:
        return "B"
    bearing = math.degrees(math.atan2(float((weights * y).sum()), float((weights * x).sum())))
    turn = screen.TURN_DEG
    return "T" if bearing > turn else "A" if bearing < -turn else "F"


def oracle_changes(
    x: np.ndarray, behind: np.ndarray, share: np.ndarray, starts: np.ndarray
) -> np.ndarray:
    """(D,) bool: whether covering the points the track puts behind changes the map rule's
    command at each decision (bearing classes by :func:`side_command`, a blank map its own
    class: an approximation of ``screen.py``'s, which follows the map's look further)."""
    ix, iy = FEATURES.index("x"), FEATURES.index("y toward the side")
    ends = np.append(starts[1:], len(x))
    changed = np.zeros(len(starts), dtype=bool)
    for d, (a, b) in enumerate(zip(starts, ends, strict=True)):
        if not behind[a:b].any():
            continue
        px, py, w = x[a:b, ix], x[a:b, iy], share[a:b]
        changed[d] = side_command(px, py, w) != side_command(px, py, w * ~behind[a:b])
    return changed


class TipNet:
    """The fitted network: standardised features, ``HIDDEN`` tanh units, a logistic output."""

    def __init__(self, model: dict[str, Any]) -> None:
        self.mean = np.asarray(model["mean"])
        self.scale = np.asarray(model["scale"])
        self.w1, self.b1 = np.asarray(model["w1"]), np.asarray(model["b1"])
        self.w2, self.b2 = np.asarray(model["w2"]), float(model["b2"])
        self.level = model.get("level", "points")

    @classmethod
    def load(cls, path: Path) -> TipNet:
        model = json.loads(path.read_text())
        names = DECISION_FEATURES if model.get("level") == "decisions" else FEATURES
        if model.get("features") != list(names):
            raise SystemExit(f"{path}: its features are not this script's")
        return cls(model)

    def score(self, x: np.ndarray) -> np.ndarray:
        hidden = np.tanh(((x - self.mean) / self.scale) @ self.w1 + self.b1)
        return 1.0 / (1.0 + np.exp(-(hidden @ self.w2 + self.b2)))


def fit(
    x: np.ndarray, y: np.ndarray, share: np.ndarray, negative_keep: float = NEGATIVE_KEEP
) -> dict[str, Any]:
    """Fit the network to samples ``x`` (P, F) labelled ``y`` (P,) bool, each weighing its
    ``share`` (P,) (points: of its decision's fresh felt; the weights normalised to a mean of 1),
    on every positive sample and ``negative_keep`` of the others."""
    rng = np.random.default_rng(SEED)
    kept = y | (rng.random(len(y)) < negative_keep)
    x, y, share = x[kept], y[kept], np.where(y[kept], share[kept], share[kept] / negative_keep)
    mean, scale = x.mean(axis=0), x.std(axis=0)
    scale[scale == 0.0] = 1.0
    z = (x - mean) / scale
    weight = share / share.mean()
    target = y.astype(np.float64)
    params = [
        rng.normal(0.0, 1.0 / math.sqrt(z.shape[1]), (z.shape[1], HIDDEN)),
        np.zeros(HIDDEN),
        rng.normal(0.0, 1.0 / math.sqrt(HIDDEN), HIDDEN),
        np.zeros(1),
    ]
    moments = [np.zeros_like(p) for p in params]
    squares = [np.zeros_like(p) for p in params]
    n = len(z)
    for epoch in range(1, EPOCHS + 1):
        w1, b1, w2, b2 = params
        hidden = np.tanh(z @ w1 + b1)
        p = 1.0 / (1.0 + np.exp(-(hidden @ w2 + b2[0])))
        d_out = weight * (p - target) / n
        d_hidden = np.outer(d_out, w2) * (1.0 - hidden**2)
        grads = [
            z.T @ d_hidden + DECAY * w1,
            d_hidden.sum(axis=0),
            hidden.T @ d_out + DECAY * w2,
            np.array([d_out.sum()]),
        ]
        for k, g in enumerate(grads):
            moments[k] = 0.9 * moments[k] + 0.1 * g
            squares[k] = 0.999 * squares[k] + 0.001 * g * g
            step = moments[k] / (1 - 0.9**epoch)
            params[k] = params[k] - RATE * step / (np.sqrt(squares[k] / (1 - 0.999**epoch)) + 1e-8)
        if epoch % 500 == 0:
            loss = -float(
                (
                    weight * (target * np.log(p + 1e-12) + (1 - target) * np.log(1 - p + 1e-12))
                ).mean()
            )
            print(f"epoch {epoch}: weighted log loss {loss:.4f}", flush=True)
    w1, b1, w2, b2 = params
    return {
        "level": "points",
        "features": list(FEATURES),
        "mean": mean.tolist(),
        "scale": scale.tolist(),
        "w1": w1.tolist(),
        "b1": b1.tolist(),
        "w2": w2.tolist(),
        "b2": float(b2[0]),
    }


def report(net: TipNet, x: np.ndarray, y: np.ndarray, share: np.ndarray) -> None:
    """Print, per threshold, the share of the behind felt (weighed by share) the network leaves
    out and the share of the other fresh felt it leaves out."""
    p = net.score(x)
    for t in (0.3, 0.5, 0.7, 0.9):
        gone = p >= t
        hit = float(share[gone & y].sum()) / max(float(share[y].sum()), 1e-12)
        miss = float(share[gone & ~y].sum()) / max(float(share[~y].sum()), 1e-12)
        print(f"threshold {t}: leaves out {hit:.1%} of the behind felt, {miss:.2%} of the rest")


def report_decisions(
    net: TipNet, x: np.ndarray, y: np.ndarray, share: np.ndarray, starts: np.ndarray
) -> None:
    """Print, per threshold, how many of the decisions whose command the track's cover changes
    the network blanks, and how many of the others."""
    changed = oracle_changes(x, y, share, starts)
    print_blanks(net.score(decision_features(x, share, starts)), changed, "the cover changes")


def print_blanks(score: np.ndarray, changed: np.ndarray, what: str) -> None:
    """Print, per threshold, how many of the decisions ``changed`` (D,) bool and of the others
    a network scoring them ``score`` (D,) blanks."""
    for t in (0.3, 0.5, 0.7, 0.9):
        blank = score >= t
        print(
            f"threshold {t}: blanks {int((blank & changed).sum())} of the {int(changed.sum())}"
            f" decisions {what}, {int((blank & ~changed).sum())} of the others"
        )


def tipnet_test(net: TipNet, threshold: float) -> Any:
    """A ``screen.py`` test: the fresh points the network scores at ``threshold`` or more."""

    def test(memory: FreshFeltMemory, chosen: np.ndarray) -> np.ndarray:
        weights = memory._weights_now  # type: ignore[attr-defined]
        key = (chosen.tobytes(), weights[chosen].tobytes(), memory._points[-1].tobytes())
        if SCORED.get("key") != key:  # the screen's copies of one decision score it once
            if net.level == "decisions":
                decision = one_decision(memory, chosen, weights)[None, :]
                SCORED["score"] = np.full(len(chosen), float(net.score(decision)[0]))
            else:
                SCORED["score"] = net.score(features(memory, chosen, weights))
            SCORED["key"] = key
        return SCORED["score"] >= threshold

    return test


def gated(gate: Any, test: Any) -> Any:
    """A ``screen.py`` test leaving out the fresh points both ``gate`` and ``test`` leave out."""

    def both(memory: FreshFeltMemory, chosen: np.ndarray) -> np.ndarray:
        return gate(memory, chosen) & test(memory, chosen)

    return both


def _take(flag: str) -> str:
    at = sys.argv.index(flag)
    value = sys.argv[at + 1]
    del sys.argv[at : at + 2]
    return value


def main() -> None:
    if len(sys.argv) < 2:
        raise SystemExit("usage: tip_classifier.py MODE ... (see the module docstring)")
    mode = sys.argv.pop(1)
    if mode == "collect":
        folder = DATA["dir"] = Path(_take("--data"))
        folder.mkdir(parents=True, exist_ok=True)
        for old in folder.glob("points_*.pkl"):
            old.unlink()
        oracle_visited.main(CollectMemory)
    elif mode == "collect-commands":
        if "--side-look" in sys.argv:
            sys.argv.remove("--side-look")
            SIDE["look"] = True
        folder = DATA["dir"] = Path(_take("--data"))
        folder.mkdir(parents=True, exist_ok=True)
        for old in folder.glob("decisions_*.pkl"):
            old.unlink()
        oracle_visited.NOW["combine"], oracle_visited.NOW["cover_from_m"] = "cover", COVER_FROM_M
        oracle_visited.main(CommandMemory)
    elif mode == "fit-commands":
        x, changes = load_decisions(Path(_take("--data")))
        print(f"{len(changes)} decisions, the oracle changes the command at {changes.sum()}")
        model = fit(x, changes, np.ones(len(changes)), negative_keep=1.0)
        model.update(level="decisions", features=list(DECISION_FEATURES))
        Path(_take("--model")).write_text(json.dumps(model) + "\n")
        print_blanks(TipNet(model).score(x), changes, "the oracle changes")
    elif mode == "cross-rooms":
        folder = Path(_take("--data"))
        if "--side-look" in sys.argv:  # part 32: the same records without and with the side look
            print("without the side look:")
            cross_rooms(folder, columns=len(DECISION_FEATURES))
            print("with the side look:")
        cross_rooms(folder)
    elif mode == "fit":
        x, y, share, starts = load_points(Path(_take("--data")))
        print(f"{len(starts)} decisions, {len(y)} fresh points, {y.mean():.1%} behind")
        model = fit(x, y, share)
        Path(_take("--model")).write_text(json.dumps(model) + "\n")
        report(TipNet(model), x, y, share)
    elif mode == "fit-decisions":
        x, y, share, starts = load_points(Path(_take("--data")))
        changed = oracle_changes(x, y, share, starts)
        print(f"{len(starts)} decisions, the track's cover changes {changed.sum()}")
        decisions = decision_features(x, share, starts)
        model = fit(decisions, changed, np.ones(len(changed)), negative_keep=1.0)
        model.update(level="decisions", features=list(DECISION_FEATURES))
        Path(_take("--model")).write_text(json.dumps(model) + "\n")
        report_decisions(TipNet(model), x, y, share, starts)
    elif mode == "report":
        x, y, share, starts = load_points(Path(_take("--data")))
        net = TipNet.load(Path(_take("--model")))
        print(f"{len(starts)} decisions, {len(y)} fresh points, {y.mean():.1%} behind")
        if net.level == "decisions":
            report_decisions(net, x, y, share, starts)
        else:
            report(net, x, y, share)
    elif mode in ("screen", "drive"):
        net = TipNet.load(Path(_take("--model")))
        if mode == "screen":
            thresholds = [float(t) for t in _take("--thresholds").split(",")]
        else:
            thresholds = [float(_take("--threshold"))]
        gate = _take("--gate") if "--gate" in sys.argv else None
        if gate is not None and gate not in screen.TESTS:
            raise SystemExit(f"--gate takes one of: {', '.join(screen.TESTS)}")
        names = []
        for t in thresholds:
            test = tipnet_test(net, t)
            if gate is not None:  # part 33: the gate's test, only where the network agrees
                test = gated(screen.TESTS[gate], test)
            screen.TESTS[f"tipnet_{t}"] = test
            names.append(f"tipnet_{t}")
        if mode == "screen":
            sys.argv[1:1] = ["--tests", ",".join(names)]
        else:
            sys.argv[1:1] = ["--drive", names[0]]
        screen.main()
    else:
        raise SystemExit(
            "the first argument is collect, collect-commands, fit, fit-decisions, fit-commands,"
            " cross-rooms, report, screen or drive"
        )


if __name__ == "__main__":
    main()
