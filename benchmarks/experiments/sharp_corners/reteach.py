"""Part 52 of ``README.md``: each repetition of a study taught again, in the same room and on the
same trials, from another demonstration and other fits.

A repetition's seed gives its room (``repetition_preset``) and three streams
(``repetition_streams``): the demonstration's (the road library's drive and the human model's
lapses and nudges), the learner's fits' and the trials'. This script replaces the first two by
streams of their own, drawn from the repetition's seed under :data:`AGAIN` (no other stream of
the repetition uses it), and keeps the room and the trials' stream: the same room and the same
loops, lapped by a learner taught there once more. With ``--keep-demonstration`` only the fits'
stream is drawn again: the same demonstration, fitted again (part 53); its fits' stream is the
one a run without it uses, so the two differ only in the demonstration. With ``--combine`` (and
``--cover-from``) every ``fresh_felt`` map is part 12's oracle's, as ``oracle_learner.py`` makes
it. The study's jobs run in this process (``--seed N``: only seed N's, so that processes can
share one output folder). The jobs' results record the study's configuration, not that they were
taught again (the folder's name and the README say so): ``lfd-track study`` pointed at such a
folder would take its jobs for the study's own and run none.

    .venv/bin/python benchmarks/experiments/sharp_corners/reteach.py --seed 102 --study benchmarks/experiments/sharp_corners/rooms30.toml --out benchmarks/experiments/sharp_corners/results/rooms30_again
"""

from __future__ import annotations

import argparse
import functools
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_learner  # noqa: E402
import oracle_visited  # noqa: E402

from lfd_track.benchmark import runner  # noqa: E402

#: spawn key of the streams a repetition is taught again from ("again" in ASCII)
AGAIN = 0x616761696E
_streams = runner.repetition_streams


def streams_again(seed: int, keep_demonstration: bool = False) -> tuple[int, int, int]:
    """(demonstration, learning, trials) seeds of the repetition with seed ``seed``, taught
    again: the first two drawn under :data:`AGAIN` (with ``keep_demonstration`` the first the
    repetition's own), the trials' the repetition's own."""
    own_demo, _, trial_seed = _streams(seed)
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(AGAIN,)))
    demo_seed, ga_seed = (int(x) for x in rng.integers(0, 2**62, size=2))
    return own_demo if keep_demonstration else demo_seed, ga_seed, trial_seed


def main() -> None:
    parser = argparse.ArgumentParser(
        description="Teach every repetition of a study again in the same room on the same trials."
    )
    parser.add_argument("--study", required=True, help="the study file")
    parser.add_argument("--out", required=True, help="the output folder")
    parser.add_argument("--seed", type=int, help="run only this seed's jobs")
    parser.add_argument("--combine", choices=oracle_visited.COMBINES, help="the oracle's map")
    parser.add_argument("--cover-from", type=float, default=0.0, metavar="M")
    parser.add_argument(
        "--keep-demonstration", action="store_true", help="draw only the fits' stream again"
    )
    args = parser.parse_args()
    if args.combine is not None:
        oracle_learner.use_oracle(args.combine, args.cover_from)
    elif args.cover_from:
        raise SystemExit("--cover-from takes metres >= 0, with --combine cover")
    # run_repetition looks the name up at each call
    runner.repetition_streams = functools.partial(  # type: ignore[assignment]
        streams_again, keep_demonstration=args.keep_demonstration
    )
    oracle_learner.run_in_process(args.study, args.out, args.seed, tables=False)


if __name__ == "__main__":
    main()
