"""How ``beatlog test`` scales with workers: a generated suite of long logs, and a small one.

The long suite is N specs, each on its own copy of a 35,000-cycle lockstep rover log
(17.5 minutes of robot time), so every worker reads its own file. The small suite is
the dog's committed suite. Each round runs ``beatlog test -j W`` for every worker count
W asked for, alternately, so a slow stretch of the machine hits them all; each figure is
the best of the rounds. Speed-up is the wall time with one worker over the wall time with
W; efficiency is speed-up / W (the issue's target: at least 0.8 up to the machine's cores).
CPU time (``resource.getrusage(RUSAGE_CHILDREN)``) says what the workers cost beyond one
process. A small suite must never be slower with more workers than with one.

Run it as ``python bench/bench_scaling.py [--specs N] [--workers 1,2,16] [--rounds R]``;
about two minutes on 2 cores with the defaults. On a bigger machine give its core count
in ``--workers`` (the default is 1, 2 and every core of this one).
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
from pathlib import Path

from rich.console import Console
from rich.table import Table

from beatlog_examples.dog import SUITE_DIR
from beatlog_examples.rover import record_lockstep
from bench_dask import run_suite
from bench_suite import bench_spec

DURATION_S = 1050.0
"""Robot time of each spec's log: 17.5 minutes, 35,000 cycles at 30 ms."""


def worker_counts(text: str) -> list[int]:
    counts = sorted({int(part) for part in text.split(",") if part.strip()})
    if not counts or counts[0] < 1:
        raise argparse.ArgumentTypeError(f"expected worker counts such as 1,2,8, got {text!r}")
    return counts


def long_suite(root: Path, specs: int) -> Path:
    """``specs`` DTCs, each on its own copy of one long rover log."""
    log = root / "rover.beatlog"
    record_lockstep(log, duration_s=DURATION_S, seed=1)
    folder = root / "long"
    folder.mkdir()
    for index in range(specs):
        shutil.copyfile(log, folder / f"rover-{index:02}.beatlog")
        spec = bench_spec(f"rover-{index:02}", f"rover-{index:02}.beatlog")
        (folder / f"rover-{index:02}.dtc.toml").write_text(spec, encoding="utf-8")
    return folder


def main() -> None:
    cores = os.cpu_count() or 1
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--specs", type=int, default=16, help="long specs in the suite")
    parser.add_argument(
        "--workers",
        type=worker_counts,
        default=worker_counts(f"1,2,{cores}"),
        help="worker counts to try, comma-separated (default: 1, 2 and all cores)",
    )
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds")
    args = parser.parse_args()
    console = Console()
    with tempfile.TemporaryDirectory() as scratch:
        suites = {"long": long_suite(Path(scratch), args.specs), "dog": SUITE_DIR}
        best: dict[tuple[str, int], tuple[float, float]] = {}
        for _ in range(args.rounds):
            for name, folder in suites.items():
                for workers in args.workers:
                    wall, cpu = run_suite(folder, ["-j", str(workers)])
                    key = (name, workers)
                    if key not in best or wall < best[key][0]:
                        best[key] = (wall, cpu)
    table = Table(
        title=f"beatlog test -j W: {args.specs} specs of 35,000 cycles and the dog's suite "
        f"(best of {args.rounds}; {cores} cores here)"
    )
    for column in ("suite", "W", "wall", "speed-up", "efficiency", "CPU", "CPU / one worker's"):
        table.add_column(column, justify="right")
    for name in suites:
        one_wall, one_cpu = best[(name, args.workers[0])]
        for workers in args.workers:
            wall, cpu = best[(name, workers)]
            speedup = one_wall / wall
            table.add_row(
                name,
                str(workers),
                f"{wall:.2f} s",
                f"{speedup:.2f}×",
                f"{speedup / workers * args.workers[0]:.2f}",
                f"{cpu:.2f} s",
                f"{cpu / one_cpu:.2f}",
            )
    console.print(table)
    console.print(
        "targets: efficiency ≥ 0.8 on the long suite up to the cores; the dog's suite "
        "no slower with more workers than with one"
    )


if __name__ == "__main__":
    main()
