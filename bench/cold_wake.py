"""How slow is the first work after a 30 ms sleep on this machine? A baseline for recording cost.

The recorder's per-cycle cost on the control thread is measured right after the
heartbeat wakes the thread. On some machines (VMs especially) any code runs far
slower just after a sleep. This script times three things after the same 30 ms
sleep and back to back: a trivial sum, a bare queue put, and the recorder's own
work (encode one rover cycle and queue it).

    python bench/cold_wake.py
"""

from __future__ import annotations

import queue
import time
from collections.abc import Callable

import numpy as np
from rich.console import Console
from rich.table import Table

from beatlog.log.format import payload_encoder
from beatlog_examples.rover.behaviors import RoverState

SAMPLES = 300
SLEEP_S = 0.03


def percentiles(run: Callable[[], object], *, sleep_s: float) -> tuple[float, float]:
    """p50 and p99 in µs of ``run`` called after sleeping ``sleep_s`` (0: back to back)."""
    times = []
    for _ in range(SAMPLES):
        if sleep_s:
            time.sleep(sleep_s)
        start = time.perf_counter_ns()
        run()
        times.append(time.perf_counter_ns() - start)
    p50, p99 = np.percentile(np.asarray(times) / 1e3, [50, 99])
    return float(p50), float(p99)


def main() -> None:
    encoder = payload_encoder()
    sink: queue.SimpleQueue[object] = queue.SimpleQueue()
    state = RoverState()
    outputs = {"speed": 0.35, "turn_rate": 0.0}
    cycle: tuple[object, ...] = (30_000_000, state, [(1, "clear", "turning_left")], [], outputs, [])

    def record_cycle() -> None:
        sink.put((0, encoder.encode(cycle)))

    def drain() -> None:
        while not sink.empty():
            sink.get_nowait()

    work: dict[str, Callable[[], object]] = {
        "sum(range(100))": lambda: sum(range(100)),
        "SimpleQueue.put": lambda: sink.put(cycle),
        "encode one cycle + put (the recorder's append)": record_cycle,
    }
    table = Table(title=f"µs per call, {SAMPLES} calls each")
    for column in ("work", "after 30 ms sleep p50", "p99", "back to back p50", "p99"):
        table.add_column(column, justify="left" if column == "work" else "right")
    for name, run in work.items():
        cold = percentiles(run, sleep_s=SLEEP_S)
        hot = percentiles(run, sleep_s=0.0)
        drain()
        table.add_row(name, *(f"{value:.1f}" for value in (*cold, *hot)))
    Console().print(table)


if __name__ == "__main__":
    main()
