"""Round 25, an exploratory look at the room that breaks the rule: which drawn setting does it?

Round 25's validation room of repetition 1 (seed 101) costs the hand-written rule on the map most
of its laps: 5 of its 20 validation laps and 3 of 6 training-track runs, where the same loops in
the paper world give 12 and 6 of 6. Here the rule (``../../generalization/rules.py``, the map of
``rooms_round25.toml``'s incumbent) drives repetitions 0-1 of seed 101 in worlds that draw only
part of the room, each part's preset listing every range of ``envs/randomized.toml`` in its order
with the rest pinned at the paper's values (so the part drawn is exactly the full room's): the
paper world; the look and the mount (``../round22/presets/``); the camera and the treads
(``../round23/presets/``); and within the look the colours, the light, the sensor, and each of
the sensor's four settings (``presets/look_*.toml``). Exploratory: one room, no rule decides
anything on it; it points at what a controlled experiment on other rooms should test.

    .venv/bin/python benchmarks/experiments/human_goal/round25/room_dissection.py --workers 2

Writes ``results/room_dissection.md`` (some 40 s per world on two workers).
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from room_measures import repetition_laps  # noqa: E402

REPO = HERE.parents[3]
STUDY = HERE / "rooms_round25.toml"
RULES = REPO / "benchmarks" / "experiments" / "generalization" / "rules.py"
CONDITION = "rooms.round20+visual"
GOAL = HERE.parent
#: (label, preset: a shipped name or a file) in the order of the table.
WORLDS = [
    ("paper world", "paper"),
    ("full room", "randomized"),
    ("look only", GOAL / "round22/presets/rooms_look.toml"),
    ("mount and treads only", GOAL / "round22/presets/rooms_mount.toml"),
    ("camera only", GOAL / "round23/presets/rooms_camera.toml"),
    ("treads only", GOAL / "round23/presets/rooms_treads.toml"),
    ("look: colours only", HERE / "presets/look_colours.toml"),
    ("look: light only", HERE / "presets/look_light.toml"),
    ("look: sensor only", HERE / "presets/look_sensor.toml"),
    ("sensor: exposure target only", HERE / "presets/look_exposure.toml"),
    ("sensor: white-balance cast only", HERE / "presets/look_white_balance.toml"),
    ("sensor: noise only", HERE / "presets/look_noise.toml"),
    ("sensor: vignetting only", HERE / "presets/look_vignetting.toml"),
]
MAP = ["branch_side=true", "branch_window=commands", "motion=visual"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=1)
    args = parser.parse_args()
    text = STUDY.read_text(encoding="utf-8")
    lines = [
        "# The rule in parts of round 25's room 1 (seed 101, repetitions 0-1)",
        "",
        "Loop laps of 20 and training-track runs of 6 per repetition; the rule on the map of",
        f"`rooms_round25.toml`'s `{CONDITION}`. Exploratory: one room, nothing decided on it.",
        "",
        "| world | repetition 0: loops | training | repetition 1: loops | training |",
        "|---|---|---|---|---|",
    ]
    with tempfile.TemporaryDirectory() as tmp:
        for k, (label, preset) in enumerate(WORLDS):
            study = Path(tmp) / f"world{k}.toml"
            body = re.sub(r'(?m)^preset = "randomized"$', f'preset = "{preset}"', text)
            if preset == "paper":
                body = re.sub(r'(?m)^room = "per_repetition"\n', "", body)
            study.write_text(body, encoding="utf-8")
            out = Path(tmp) / f"out{k}"
            command = [sys.executable, str(RULES), "--study", str(study), "--condition"]
            command += [CONDITION, "--rule", "map-rule", "--repetitions", "2"]
            command += [arg for pair in MAP for arg in ("--map", pair)]
            command += ["--out", str(out), "--workers", str(args.workers)]
            subprocess.run(command, check=True, capture_output=True, cwd=REPO)
            laps = repetition_laps(out)
            lines.append(f"| {label} | {laps[0][0]} | {laps[0][1]} | {laps[1][0]} | {laps[1][1]} |")
            print(lines[-1], flush=True)
    (HERE / "results").mkdir(exist_ok=True)
    (HERE / "results" / "room_dissection.md").write_text("\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
