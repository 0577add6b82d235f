"""The determinism audit's cost on the example rover, measured in one run.

The script records a 35,000-cycle rover log (1050 s of robot time at 30 ms), then
times a plain replay and ``audit`` (two replays, at once, in the two audit interpreters
that the first audit starts and the later ones reuse, kept by one ``Auditors``)
alternately, ``REPEATS`` times each. Wall time is ``time.perf_counter``; CPU time is
user + system of this process and of the audit interpreters (``resource.getrusage``;
the interpreters' own is counted as they go, read from ``/proc``, since they live on).
It reports the first audit (with the interpreters' start-up), the fastest of the others
and the plain replay's fastest, and their ratios. Nothing here asserts a timing.

Run it as ``python bench/bench_audit.py``; it takes about 10 s on 2 cores.
"""

from __future__ import annotations

import os
import resource
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import beatlog
from beatlog.audit.replays import Auditors, audit
from beatlog_examples.rover import record_lockstep

DURATION_S = 1050.0
REPEATS = 4
SYSTEM = "beatlog_examples.rover:system"
TICKS = os.sysconf("SC_CLK_TCK")


def descendants_cpu() -> float:
    """CPU seconds so far of this process's living children (the audit interpreters)."""
    total = 0.0
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == os.getpid():  # ppid
            total += (int(fields[11]) + int(fields[12])) / TICKS  # utime, stime
    return total


def cpu() -> float:
    me = resource.getrusage(resource.RUSAGE_SELF)
    done = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + done.ru_utime + done.ru_stime + descendants_cpu()


def timed(work: Callable[[], object]) -> tuple[float, float]:
    """Wall and CPU seconds of ``work()``."""
    wall, started = time.perf_counter(), cpu()
    work()
    return time.perf_counter() - wall, cpu() - started


def main() -> None:
    with tempfile.TemporaryDirectory() as folder, Auditors() as auditors:
        log = Path(folder) / "rover.beatlog"
        cycles = record_lockstep(log, duration_s=DURATION_S, seed=1).cycles
        replays: list[tuple[float, float]] = []
        audits: list[tuple[float, float]] = []
        for _ in range(REPEATS):
            replays.append(timed(lambda: beatlog.replay(log, SYSTEM)))
            audits.append(timed(lambda: audit(log, SYSTEM, auditors=auditors)))
        assert beatlog.replay(log, SYSTEM).ok
        assert audit(log, SYSTEM, auditors=auditors).ok
    first = audits[0]
    replay_wall, replay_cpu = min(w for w, _ in replays), min(c for _, c in replays)
    audit_wall, audit_cpu = min(w for w, _ in audits[1:]), min(c for _, c in audits[1:])
    print(f"rover log: {cycles:,} cycles, {DURATION_S:g} s of robot time")
    print(f"plain replay, best of {REPEATS}: wall {replay_wall:.2f} s, CPU {replay_cpu:.2f} s")
    print(f"first audit (starts the interpreters): wall {first[0]:.2f} s, CPU {first[1]:.2f} s")
    print(f"audit, best of {REPEATS - 1} more: wall {audit_wall:.2f} s, CPU {audit_cpu:.2f} s")
    print(f"audit / replay: wall {audit_wall / replay_wall:.1f}, CPU {audit_cpu / replay_cpu:.1f}")


if __name__ == "__main__":
    main()
