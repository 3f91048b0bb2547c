"""The learned policy with part 12's oracle: taught and driven on a map whose visited felt the
track tells (part 27 of ``README.md``).

``oracle_visited.py`` gives the map rule a ``fresh_felt`` map whose felt counts as visited where
the track says it lies behind the rover. This script gives the same map to a whole study job:
the human model's demonstration records its map inputs from it, the learner is fitted on those
cases, and the learned policy drives on it. Every ``fresh_felt`` map the job makes is
``oracle_visited.TrackVisitedMemory`` (with ``--combine`` and ``--cover-from`` as there), so the
job runs in this process (its jobs one after another); ``--seed N`` runs only the jobs of seed
N, so that two processes can share one output folder, one seed each. The jobs' results are all
it writes: its folder is not beside the study file it runs, where the study's tables belong.

"Behind the rover" is judged along the way the rover is going. In the trials that is the
episode's track and progress. In the demonstration the human model drives a lap each way of one
episode, turning round between the legs, where the episode's progress (along the loop's own
direction) falls through the second leg: there the oracle reads the leg the human is driving and
its progress along it (``ProtocolHuman.legs``, ``leg`` and ``progress_m``, updated before each
frame is perceived), so that the felt of the second leg's way ahead is not counted behind.

Its ``run_in_process`` and ``run_with_more_inputs`` also run the human-taught goal's prototype
maps (``../human_goal/round35/sides.py``, ``round36/ahead.py``), whose maps add inputs.

This is an oracle, for a measurement only: a robot does not know the track. The jobs' results
record the study's configuration, not the oracle; the folder's name and the README say which.

    .venv/bin/python benchmarks/experiments/sharp_corners/oracle_learner.py --combine cover --cover-from 0.3 --seed 100 --study benchmarks/experiments/human_goal/round33/sight.toml --out benchmarks/experiments/sharp_corners/results/oracle_visited/learner_sight_cover_from_30cm
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_visited  # noqa: E402

from lfd_track.core.commands import Command  # noqa: E402
from lfd_track.envs.track_env import LfDTrackEnv  # noqa: E402
from lfd_track.policy.memory import FreshFeltConfig, FreshFeltMemory  # noqa: E402
from lfd_track.study.run import load_finished, run_study  # noqa: E402
from lfd_track.study.spec import load_study  # noqa: E402
from lfd_track.study.summary import write_study_outputs  # noqa: E402
from lfd_track.teaching.scripted import ProtocolHuman  # noqa: E402

_finished = ProtocolHuman.finished


def leg_finished(self: ProtocolHuman, info: dict[str, Any]) -> bool:
    """``ProtocolHuman.finished``, then the oracle reads the leg being driven (see the module
    docstring)."""
    done = _finished(self, info)
    if not done:
        oracle_visited.NOW["track"] = self.legs[self.leg % 2]
        oracle_visited.NOW["progress_m"] = self.progress_m
    return done


def study_parser(description: str) -> argparse.ArgumentParser:
    """The command line of a script that runs a study in this process: ``--study``, ``--out``
    and ``--seed`` (a script adds its own arguments)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--study", required=True, help="the study file")
    parser.add_argument("--out", required=True, help="the study's output folder")
    parser.add_argument("--seed", type=int, help="run only this seed's jobs")
    return parser


class PrototypeMemory(FreshFeltMemory):
    """A prototype map's base: the ``fresh_felt`` map whose snapshots (``copy.copy``, which the
    perception takes before each frame) stay of the prototype's class, with its state."""

    def __copy__(self) -> PrototypeMemory:
        twin = super().__copy__()
        twin.__class__ = type(self)
        return twin  # type: ignore[return-value]

    def reset(self) -> None:
        super().reset()
        self._turned = 0.0  # [deg] net turn since the last forward command, left positive

    def _turn_or_advance(self, command: int, measured: Any) -> float | None:
        """Count ``command``'s motion: a pivot's turn adds to the net turn since the last forward
        command (``_turned``) and gives None; a forward command sets that turn to 0 and gives
        its advance [m] (unsigned)."""
        advance, turn = self._command_motion(command, measured)
        if command != Command.FORWARD:
            self._turned += turn
            return None
        self._turned = 0.0
        return abs(advance)

    def _command_motion(self, command: int, measured: Any) -> tuple[float, float]:
        """(advance [m], turn [deg, left positive]) the map moves by for ``command``: the
        ``measured`` motion, or without one the command's nominal step or pivot."""
        if measured is not None:
            return float(measured.forward_m), float(measured.turn_deg)
        if command == Command.FORWARD:
            return self._step, 0.0
        pivot = self.geometry.pivot_deg
        return 0.0, pivot if command == Command.LEFT else -pivot

    def _placed_before(
        self, points: np.ndarray, command: Command | int, directions: bool = False
    ) -> np.ndarray:
        """``points`` (N, 2) moved as :meth:`place_before` moves the map for ``command``: one
        step back for a forward command, turned one pivot the other way for a pivot (with
        ``directions``, directions: turned only)."""
        cmd = int(command)
        if cmd == Command.FORWARD:
            return points if directions else points + np.array([self._step, 0.0])
        return self._moved(points, Command.RIGHT if cmd == Command.LEFT else Command.LEFT)

    def _carried(self, points: np.ndarray, command: int, measured: Any) -> np.ndarray:
        """``points`` (N, 2) in the rover frame after ``command``: moved by its ``measured``
        motion, or without one by its nominal one (as the map moves)."""
        if measured is not None:
            return measured.move_points(points)
        return self._moved(points, command)

    def _turned_dirs(self, dirs: np.ndarray, command: int, measured: Any) -> np.ndarray:
        """Directions ``dirs`` (N, 2) in the rover frame after ``command`` (rotation only)."""
        if measured is not None:
            return measured.move_points(dirs) - measured.move_points(np.zeros((1, 2)))
        if command == Command.FORWARD:
            return dirs
        return self._moved(dirs, command)


def main() -> None:
    parser = study_parser(__doc__.splitlines()[0])
    parser.add_argument("--combine", choices=oracle_visited.COMBINES, default="oracle")
    parser.add_argument("--cover-from", type=float, default=0.0, metavar="M")
    args = parser.parse_args()
    use_oracle(args.combine, args.cover_from)
    run_in_process(args.study, args.out, args.seed, tables=False)


def use_oracle(combine: str, cover_from: float) -> None:
    """From now on every ``fresh_felt`` map this process makes is the oracle's
    (``oracle_visited.TrackVisitedMemory`` with ``combine`` and ``cover_from`` [m]), in the
    demonstration, the fits and the trials alike (see the module docstring)."""
    if cover_from and (combine != "cover" or not cover_from >= 0.0):
        raise SystemExit("--cover-from takes metres >= 0, with --combine cover")
    oracle_visited.NOW["combine"], oracle_visited.NOW["cover_from_m"] = combine, cover_from
    LfDTrackEnv.reset, LfDTrackEnv.step = (  # type: ignore[method-assign]
        oracle_visited.reset,
        oracle_visited.step,
    )
    ProtocolHuman.finished = leg_finished  # type: ignore[method-assign]
    oracle_visited.maps_made_as(oracle_visited.TrackVisitedMemory)


def run_in_process(study_file: str, out_folder: str, seed: int | None, tables: bool = True) -> None:
    """Run the study ``study_file``'s jobs (only seed ``seed``'s, if given) in this process into
    ``out_folder``, and with ``tables``, once every job of the study is there, write its tables
    (a script that changes the map in this process runs its study through this)."""
    study = load_study(study_file)
    out = Path(out_folder)
    out.mkdir(parents=True, exist_ok=True)
    mine = study
    if seed is not None:
        if seed not in study.seeds:
            raise SystemExit(f"--seed {seed}: the study's seeds are {list(study.seeds)}")
        mine = dataclasses.replace(study, seeds=(seed,))
    done = run_study(mine, out, workers=1)
    print(f"{done.ran} jobs run, {done.skipped} already there, {done.wall_s:.0f} s")
    if not tables:
        return
    try:
        finished = load_finished(study, out)
    except Exception as exc:  # another seed's jobs are still running
        print(f"tables not written yet: {exc}")
        return
    write_study_outputs(out, study, finished)
    print(f"tables written into {out}")


def run_with_more_inputs(
    memory_class: type[FreshFeltMemory],
    more: int,
    mirror_more: Callable[[np.ndarray], np.ndarray],
    description: str,
) -> None:
    """A prototype map's script: :func:`use_more_inputs`, then the study the command line names
    (``--study``, ``--out``, ``--seed``) runs in this process."""
    args = study_parser(description).parse_args()
    use_more_inputs(memory_class, more, mirror_more)
    run_in_process(args.study, args.out, args.seed)


def run_with_map(memory_class: type[FreshFeltMemory], description: str) -> None:
    """A prototype map's script with the map's own inputs: every ``fresh_felt`` map is a
    ``memory_class``, and the study the command line names runs in this process (its tables
    written when it runs every seed)."""
    args = study_parser(description).parse_args()
    oracle_visited.maps_made_as(memory_class)
    run_in_process(args.study, args.out, args.seed, tables=args.seed is None)


def use_more_inputs(
    memory_class: type[FreshFeltMemory],
    more: int,
    mirror_more: Callable[[np.ndarray], np.ndarray],
) -> None:
    """From now on every ``fresh_felt`` configuration has ``more`` inputs after the map's own (a
    mirror image mirrors the map's own as it does and the ``more`` by ``mirror_more``), and
    every ``fresh_felt`` map is a ``memory_class``."""
    post_init, mirror = FreshFeltConfig.__post_init__, FreshFeltConfig.mirror

    def with_more(self: FreshFeltConfig) -> None:
        post_init(self)
        object.__setattr__(self, "n_inputs", self.n_inputs + more)

    def mirrored(self: FreshFeltConfig, inputs: np.ndarray) -> np.ndarray:
        out = np.array(inputs, dtype=np.float64)
        out[:, :-more] = mirror(self, out[:, :-more])
        out[:, -more:] = mirror_more(out[:, -more:])
        return out

    FreshFeltConfig.__post_init__ = with_more  # type: ignore[method-assign]
    FreshFeltConfig.mirror = mirrored  # type: ignore[method-assign]
    oracle_visited.maps_made_as(memory_class)


if __name__ == "__main__":
    main()
