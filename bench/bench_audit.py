"""The determinism audit's cost on the example rover, measured in one run.

The script records a 35,000-cycle rover log (1050 s of robot time at 30 ms), then
times a plain replay and ``audit`` (two watched replays in fresh interpreters, run
at once) alternately, ``REPEATS`` times each, and reports the fastest of each and
their ratio. Nothing here asserts a timing.

Run it as ``python bench/bench_audit.py``; it takes about 10 s on 2 cores.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import beatlog
from beatlog.audit.replays import audit
from beatlog_examples.rover import record_lockstep

DURATION_S = 1050.0
REPEATS = 3
SYSTEM = "beatlog_examples.rover:system"


def main() -> None:
    with tempfile.TemporaryDirectory() as folder:
        log = Path(folder) / "rover.beatlog"
        cycles = record_lockstep(log, duration_s=DURATION_S, seed=1).cycles
        replays: list[float] = []
        audits: list[float] = []
        for _ in range(REPEATS):
            started = time.perf_counter()
            result = beatlog.replay(log, SYSTEM)
            replays.append(time.perf_counter() - started)
            started = time.perf_counter()
            report = audit(log, SYSTEM)
            audits.append(time.perf_counter() - started)
            assert result.ok
            assert report.ok, report.lines()
    replay_s, audit_s = min(replays), min(audits)
    print(f"rover log: {cycles:,} cycles, {DURATION_S:g} s of robot time")
    print(f"plain replay, best of {REPEATS}: {replay_s:.2f} s ({cycles / replay_s:,.0f} cycles/s)")
    print(f"audit, best of {REPEATS}: {audit_s:.2f} s ({cycles / audit_s:,.0f} cycles/s)")
    print(f"audit time / replay time: {audit_s / replay_s:.1f}")


if __name__ == "__main__":
    main()
