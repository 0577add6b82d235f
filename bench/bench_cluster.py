"""A cluster's costs separated: ``--dask local:W`` start-up on its own, and the overhead
per DTC of a cluster against ``-j W`` on the same DTC.

Start-up: a local cluster of W worker processes started and closed in this process
(:class:`~beatlog.suite.cluster.DaskExecutor`), wall time. Per DTC: ``beatlog test`` on
suites of 1 and of N specs of one short rover log, under ``--dask local:W`` and under
``-j W``, alternated in rounds; the cost of one more DTC is ``(T(N) - T(1)) / (N - 1)``,
in wall time and in CPU time of the command and all its processes
(``resource.getrusage(RUSAGE_CHILDREN)``, user + system). The replay's own CPU time,
measured here with ``run_spec``, is subtracted to give each runner's overhead per DTC.
Figures are medians of the rounds.

Run it as ``python bench/bench_cluster.py [--specs N] [--workers W] [--rounds R]
[--seconds S]``; about three minutes on 2 cores with the defaults.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

from beatlog.suite.cluster import DaskExecutor
from beatlog.suite.runner import run_spec
from beatlog.suite.spec import load_spec
from beatlog_examples.rover import record_lockstep
from bench_dask import run_suite
from bench_suite import write_specs


def cluster_startup(workers: int) -> float:
    """Wall time to start a local cluster of ``workers`` processes and close it."""
    started = time.perf_counter()
    with DaskExecutor(f"local:{workers}"):
        pass
    return time.perf_counter() - started


def replay_cpu(spec: Path, rounds: int) -> float:
    """Median CPU time of one replay of ``spec`` in this process (after a warm-up)."""
    loaded = load_spec(spec)
    run_spec(loaded)
    times = []
    for _ in range(rounds):
        started = time.process_time()
        run_spec(loaded)
        times.append(time.process_time() - started)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--specs", type=int, default=60, help="specs in the larger suite")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="workers")
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds")
    parser.add_argument("--seconds", type=float, default=3.0, help="robot time of the log")
    args = parser.parse_args()
    runners = {
        f"-j {args.workers}": ["-j", str(args.workers)],
        f"--dask local:{args.workers}": ["--dask", f"local:{args.workers}"],
    }
    figures: dict[tuple[str, int], list[tuple[float, float]]] = {}
    with tempfile.TemporaryDirectory() as scratch:
        root = Path(scratch)
        log = root / "short.beatlog"
        record_lockstep(log, duration_s=args.seconds, seed=1)
        [one] = write_specs(root / "one", log, 1)
        write_specs(root / "many", log, args.specs)
        replay = replay_cpu(one, 20)
        startups = []
        for _ in range(args.rounds):  # alternately, so a slow stretch of the machine hits all
            startups.append(cluster_startup(args.workers))
            for name, where in runners.items():
                for count, suite in ((1, "one"), (args.specs, "many")):
                    figures.setdefault((name, count), []).append(run_suite(root / suite, where))

    def median(name: str, count: int, index: int) -> float:
        return statistics.median(figure[index] for figure in figures[name, count])

    table = Table(
        title=f"1 and {args.specs} DTCs of {args.seconds:g} s robot time, {args.workers} "
        f"workers, medians of {args.rounds} alternating rounds; one replay: "
        f"{replay * 1000:.1f} ms CPU; local:{args.workers} start-up and close "
        f"in process: {statistics.median(startups):.2f} s wall"
    )
    for column in (
        "runner",
        "1 DTC wall",
        "1 DTC CPU",
        f"{args.specs} DTCs wall",
        f"{args.specs} DTCs CPU",
        "per DTC wall",
        "per DTC CPU",
        "overhead CPU per DTC",
    ):
        table.add_column(column, justify="left" if column == "runner" else "right")
    for name in runners:
        wall_one, cpu_one = median(name, 1, 0), median(name, 1, 1)
        wall_many, cpu_many = median(name, args.specs, 0), median(name, args.specs, 1)
        per_wall = (wall_many - wall_one) / (args.specs - 1)
        per_cpu = (cpu_many - cpu_one) / (args.specs - 1)
        table.add_row(
            name,
            f"{wall_one:.2f} s",
            f"{cpu_one:.2f} s",
            f"{wall_many:.2f} s",
            f"{cpu_many:.2f} s",
            f"{per_wall * 1000:.1f} ms",
            f"{per_cpu * 1000:.1f} ms",
            f"{(per_cpu - replay) * 1000:.1f} ms",
        )
    Console().print(table)


if __name__ == "__main__":
    main()
