"""What breaks in rooms: each of the 30 kept rooms' laps (round 20's winner and the map rule on
the same map) beside the room's drawn settings, and which settings part the rooms that lap 85 %
of their loops from those that do not.

Reads only committed results (``results/test_rooms20/`` and
``../test_round9/results/rules_rooms/``; with ``--round 27``, round 27's winner and the rule on
its map with the same colour balance, ``../test_round27/results/test_rooms27/`` and
``../test_round27/results/rules_rooms27/``; with ``--round 33``, round 33's winner and the rule
on its map, ``../test_round33/results/``; with ``--round 33-seeds3to5``, the same on seeds 3-5)
and redraws each repetition's room as the study drew
it (``repetition_preset``); nothing is run or chosen on it.

    .venv/bin/python benchmarks/experiments/human_goal/test_round20/rooms_breakdown.py [--round 27|33|33-seeds3to5]

writes ``results/rooms_breakdown.md`` (``../test_round27/results/rooms_breakdown.md``,
``../test_round33/results/rooms_breakdown.md``, ``rooms_breakdown_seeds3to5.md``; a few
seconds).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from lfd_track.benchmark.runner import repetition_preset, repetition_seeds
from lfd_track.study.spec import load_study
from lfd_track.utils.atomic import atomic_write_text

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from room_measures import spearman  # noqa: E402

HERE = Path(__file__).resolve().parent
ROUND27 = HERE.parent / "test_round27"
ROUND33 = HERE.parent / "test_round33"
#: Per round: (title, study file, the learned policy's results, the rule's, the page written).
ROUNDS = {
    "20": (
        "round 20's winner",
        HERE / "test_rooms20.toml",
        HERE / "results" / "test_rooms20" / "rooms.round20+visual",
        HERE.parent / "test_round9" / "results" / "rules_rooms" / "map-rule",
        HERE / "results" / "rooms_breakdown.md",
    ),
    "27": (
        "round 27's winner, with the colour balance",
        ROUND27 / "test_rooms27.toml",
        ROUND27 / "results" / "test_rooms27" / "rooms.round20+visual+balance",
        ROUND27 / "results" / "rules_rooms27" / "map-rule",
        ROUND27 / "results" / "rooms_breakdown.md",
    ),
    "33": (
        "round 33's winner, fresh felt in sight along felt",
        ROUND33 / "test_rooms33.toml",
        ROUND33 / "results" / "test_rooms33" / "rooms.round27+sight",
        ROUND33 / "results" / "rules_rooms33" / "map-rule",
        ROUND33 / "results" / "rooms_breakdown.md",
    ),
    "33-seeds3to5": (
        "round 33's winner on seeds 3-5, fresh felt in sight along felt",
        ROUND33 / "seeds3to5_rooms33.toml",
        ROUND33 / "results" / "seeds3to5_rooms33" / "rooms.round27+sight",
        ROUND33 / "results" / "rules_seeds3to5_rooms33" / "map-rule",
        ROUND33 / "results" / "rooms_breakdown_seeds3to5.md",
    ),
}


def laps(folder: Path) -> dict[tuple[int, int], dict[str, list[int]]]:
    """Per (seed, repetition): [laps, trials] of the loops and of the testing track."""
    out: dict[tuple[int, int], dict[str, list[int]]] = {}
    for path in sorted(folder.glob("seed*/results.json")):
        data = json.loads(path.read_text())
        for o in data["outcomes"]:
            if o["track"] == "training":
                continue
            kind = "testing" if o["track"] == "testing" else "loops"
            cell = out.setdefault(
                (data["seed"], o["repetition"]), {"loops": [0, 0], "testing": [0, 0]}
            )
            cell[kind][0] += o["failure"] is None
            cell[kind][1] += 1
    return out


def settings(preset) -> dict[str, float]:  # noqa: ANN001 - a Preset
    """The drawn settings that vary between rooms, as numbers."""
    felt = np.asarray(preset.appearance.felt_rgb, dtype=float)
    carpet = np.asarray(preset.appearance.carpet_rgb, dtype=float)
    return {
        "felt-carpet contrast": float(np.linalg.norm(felt - carpet)),
        "ambient light": preset.lighting.ambient,
        "light pool": preset.lighting.pool_strength,
        "shadow darkness": preset.lighting.shadow_darkness,
        "exposure target": preset.sensor.exposure_target,
        "sensor noise": preset.sensor.noise_std,
        "white-balance cast": preset.sensor.white_balance_cast,
        "camera pitch [deg]": preset.camera.pitch_deg,
        "camera height [m]": preset.camera.height_m,
        "vertical fov [deg]": preset.camera.vfov_deg,
        "slip noise": preset.rover.slip_noise_std,
        "motor asymmetry": preset.rover.motor_asymmetry_std,
    }


BAR = 0.85  # the goal's share of loop laps in every room


def at_least(k: int, n: int, p: float) -> float:
    """The chance of at least ``k`` successes in ``n`` trials of chance ``p`` (binomial)."""
    return sum(math.comb(n, i) * p**i * (1 - p) ** (n - i) for i in range(k, n + 1))


def against_chance(done: np.ndarray, n: int) -> str:
    """The cells after a driver's name in the against-chance table, for the rooms' lapped loop
    laps ``done`` (rooms,) of ``n`` each: the pooled rate p, the rooms at 85 %, the rooms
    expected there if every room lapped at p, the rooms' variance and the binomial's."""
    p = float(done.sum()) / (n * len(done))
    need = math.ceil(BAR * n)
    return (
        f"{p:.3f} | {int((done >= need).sum())} of {len(done)} |"
        f" {len(done) * at_least(need, n, p):.1f} | {done.var():.2f} | {n * p * (1 - p):.2f} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--round", choices=sorted(ROUNDS), default="20")
    title, study_file, learned_folder, rule_folder, out = ROUNDS[parser.parse_args().round]
    study = load_study(study_file)
    config = study.conditions[0].config
    learned, rule = laps(learned_folder), laps(rule_folder)
    rows = []
    for seed in study.seeds:
        for index, rep_seed in enumerate(repetition_seeds(seed, study.repetitions)):
            room = settings(repetition_preset(config, rep_seed))
            rows.append(((seed, index), room, learned[(seed, index)], rule[(seed, index)]))
    names = list(rows[0][1])
    md = [f"# What breaks in rooms ({title}, 30 kept rooms)", ""]
    md += ["Loop laps and testing laps per room, the learned policy and the map rule on the same"]
    md += ["map; the room's drawn settings beside them.", ""]
    md += [
        "| seed, rep | learned loops | rule loops | learned testing | rule testing | "
        + " | ".join(names)
        + " |"
    ]
    md += ["|---" * (5 + len(names)) + "|"]
    for (seed, index), room, mine, theirs in sorted(
        rows, key=lambda r: r[2]["loops"][0] / r[2]["loops"][1]
    ):
        cells = " | ".join(f"{room[n]:.3g}" for n in names)
        md += [
            f"| {seed}, {index} | {mine['loops'][0]}/{mine['loops'][1]} | "
            f"{theirs['loops'][0]}/{theirs['loops'][1]} | {mine['testing'][0]}/6 | "
            f"{theirs['testing'][0]}/6 | {cells} |"
        ]
    good = [r for r in rows if r[2]["loops"][0] >= 0.85 * r[2]["loops"][1]]
    bad = [r for r in rows if r[2]["loops"][0] < 0.85 * r[2]["loops"][1]]
    md += ["", f"Rooms at 85 % of their loop laps: {len(good)}; under: {len(bad)}. Mean of each"]
    md += ["setting in the two groups, and the rank correlation (Spearman) of each setting with"]
    md += ["the learned policy's loop share over all 30 rooms:", ""]
    md += [
        "| setting | rooms at 85 % | rooms under | Spearman with loop share |",
        "|---|---|---|---|",
    ]
    share = np.array([r[2]["loops"][0] / r[2]["loops"][1] for r in rows])

    for n in names:
        values = np.array([r[1][n] for r in rows])
        rho = spearman(values, share)
        md += [
            f"| {n} | {np.mean([r[1][n] for r in good]):.3g} | "
            f"{np.mean([r[1][n] for r in bad]):.3g} | {rho:+.2f} |"
        ]
    rule_share = np.array([r[3]["loops"][0] / r[3]["loops"][1] for r in rows])
    rho = spearman(rule_share, share)
    md += [
        "",
        f"Spearman between the learned policy's and the rule's loop share per room: {rho:+.2f}",
    ]
    md += ["(each room drives its own draw of 10 test loops, the same for both, so a room's share"]
    md += ["mixes its settings with how sharp its loops are)."]
    md += ["", "## The bar of 85 % in every room, against chance", ""]
    md += ["If every room lapped at the pooled rate p, a room's n loop laps would be binomial: the"]
    md += ["rooms expected at 85 % of their laps, and the spread of the rooms' laps against the"]
    md += ["binomial's (a larger spread: rooms, with their loops, differ beyond chance):", ""]
    md += ["| driver | pooled p | rooms at 85 % | expected at p | laps' variance | binomial's |"]
    md += ["|---|---|---|---|---|---|"]
    n = rows[0][2]["loops"][1]  # loop laps per room
    need = math.ceil(BAR * n)
    for driver, column in (("learned", 2), ("rule", 3)):
        done = np.array([r[column]["loops"][0] for r in rows])
        md += [f"| {driver} | {against_chance(done, n)}"]
    reach = next(
        q / 1000 for q in range(850, 1000) if at_least(need, n, q / 1000) ** len(rows) >= 0.9
    )
    md += ["", f"All {len(rows)} rooms at 85 % with probability 0.9 would take, with no spread"]
    md += [f"beyond chance, a pooled rate of {reach:.3f} over {n} laps a room."]
    atomic_write_text(out, "\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
