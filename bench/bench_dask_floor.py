"""The floor of one Dask task a DTC: the CPU a task that does nothing costs a local
cluster, submitted as ``--dask`` submits DTCs (one more as each completes, results
gathered as they complete).

A ``LocalCluster`` of W worker processes of one thread each is started and closed
twice: idle, then running N no-op tasks. The difference, per task, is the CPU the
client and scheduler (this process) and the workers (its children, counted once they
end) spend on a task alone, the least a DTC can cost on a cluster beyond its replay.

Run it as ``python bench/bench_dask_floor.py [--tasks N] [--workers W]``.
"""

from __future__ import annotations

import argparse
import logging
import resource

from distributed import Client, LocalCluster, as_completed


def _cpu(who: int) -> float:
    usage = resource.getrusage(who)
    return usage.ru_utime + usage.ru_stime


def _nothing(value: int) -> int:
    return value


def _run(tasks: int, workers: int) -> tuple[float, float]:
    """CPU seconds of this process and of the workers for a cluster running ``tasks``."""
    own, children = _cpu(resource.RUSAGE_SELF), _cpu(resource.RUSAGE_CHILDREN)
    with (
        LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.CRITICAL,
        ) as cluster,
        Client(cluster) as client,
    ):
        first = min(tasks, 2 * workers)
        completed = as_completed(client.map(_nothing, range(first), pure=False), with_results=True)
        submitted = first
        for _ in completed:
            if submitted < tasks:
                completed.update(client.map(_nothing, [submitted], pure=False))
                submitted += 1
    return _cpu(resource.RUSAGE_SELF) - own, _cpu(resource.RUSAGE_CHILDREN) - children


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", type=int, default=1000, help="no-op tasks")
    parser.add_argument("--workers", type=int, default=2, help="worker processes")
    args = parser.parse_args()
    idle_own, idle_workers = _run(0, args.workers)
    own, workers = _run(args.tasks, args.workers)
    print(
        f"a no-op task on local:{args.workers}, CPU: client and scheduler "
        f"{(own - idle_own) / args.tasks * 1000:.1f} ms, workers "
        f"{(workers - idle_workers) / args.tasks * 1000:.1f} ms"
    )


if __name__ == "__main__":
    main()
