"""Replay, the bare loop or the checked loop (``bare.py``) of one log ``times`` times
after a warm-up: for counting instructions under valgrind, which, unlike CPU time,
other processes do not disturb.

Run it as ``valgrind --tool=cachegrind --cache-sim=no python bench/replay_instructions.py
LOG MODULE:FACTORY replay|bare|checked TIMES`` with TIMES 0 and 1: the difference of
the two ``I refs`` counts, divided by the log's cycles, is one run's instructions per
cycle, start-up and warm-up left out.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bare import load_bare_inputs, replay_fresh, run_bare, run_checked
from beatlog.model.behavior import System
from beatlog.project.usercode import load_system


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("log", type=Path)
    parser.add_argument("system", help="module:factory")
    parser.add_argument("run", choices=("replay", "bare", "checked"))
    parser.add_argument("times", type=int)
    args = parser.parse_args()

    def make() -> System:
        return load_system(args.system)

    inputs = load_bare_inputs(args.log, load_system(args.system).robot_state)
    replay_fresh(args.log, make)
    run_bare(inputs, make)
    run_checked(args.log, make)
    for _ in range(args.times):
        if args.run == "replay":
            result, _ = replay_fresh(args.log, make)
            assert result.ok, result.divergence
        elif args.run == "bare":
            run_bare(inputs, make)
        else:
            run_checked(args.log, make)


if __name__ == "__main__":
    main()
