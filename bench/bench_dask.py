"""Dask against the local runner: ``beatlog test --dask local:W`` and ``beatlog test -j W``
on the same suite of long rover logs.

Each round runs, alternately, both commands on the suite and on W specs of a ten-cycle
log (their start-up: interpreter, imports, worker pool or cluster). Figures are the best
of the rounds: the wall time of each command, the CPU time of the command and all its
processes (``resource.getrusage(RUSAGE_CHILDREN)``, user + system), and the wall time
less the start-up. Both runners replay with ``run_spec``; what differs is how specs and
outcomes travel (pipes to worker processes against Dask tasks) and what starting costs.

Run it as ``python bench/bench_dask.py [--specs N] [--workers W] [--rounds R]``;
about two minutes on 2 cores with the defaults.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

from beatlog_examples.rover import record_lockstep
from bench_suite import write_specs

DURATION_S = 1050.0
"""Robot time of each spec's log: 17.5 minutes, 35,000 cycles at 30 ms."""


def children_cpu() -> float:
    """CPU time, user and system, of every child process waited for so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_suite(folder: Path, where: list[str]) -> tuple[float, float]:
    """Wall and CPU time of ``beatlog test WHERE FOLDER``, which must pass."""
    command = [sys.executable, "-m", "beatlog.cli.main", "test", *where, str(folder)]
    cpu, started = children_cpu(), time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    return time.perf_counter() - started, children_cpu() - cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--specs", type=int, default=24, help="specs in the suite")
    parser.add_argument(
        "--workers", type=int, default=os.cpu_count() or 1, help="worker processes of both"
    )
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds")
    args = parser.parse_args()
    runners = {
        f"beatlog test -j {args.workers}": ["-j", str(args.workers)],
        f"beatlog test --dask local:{args.workers}": ["--dask", f"local:{args.workers}"],
    }
    best: dict[tuple[str, str], tuple[float, float]] = {}
    with tempfile.TemporaryDirectory() as scratch:
        root = Path(scratch)
        long_log, short_log = root / "long.beatlog", root / "short.beatlog"
        record_lockstep(long_log, duration_s=DURATION_S, seed=1)
        record_lockstep(short_log, duration_s=0.3, seed=1)
        write_specs(root / "suite", long_log, args.specs)
        write_specs(root / "startup", short_log, args.workers)
        for _ in range(args.rounds):  # alternately, so a slow stretch of the machine hits all
            for name, where in runners.items():
                for suite in ("suite", "startup"):
                    wall, cpu = run_suite(root / suite, where)
                    old = best.get((name, suite), (float("inf"), float("inf")))
                    best[name, suite] = (min(old[0], wall), min(old[1], cpu))

    table = Table(
        title=f"{args.specs} specs of 35,000 cycles, {args.workers} workers, "
        f"best of {args.rounds} alternating rounds"
    )
    for column in ("runner", "wall", "CPU", "start-up wall", "start-up CPU", "wall − start-up"):
        table.add_column(column, justify="left" if column == "runner" else "right")
    for name in runners:
        (wall, cpu), (start_wall, start_cpu) = best[name, "suite"], best[name, "startup"]
        table.add_row(
            name,
            f"{wall:.2f} s",
            f"{cpu:.2f} s",
            f"{start_wall:.2f} s",
            f"{start_cpu:.2f} s",
            f"{wall - start_wall:.2f} s",
        )
    Console().print(table)


if __name__ == "__main__":
    main()
