"""Heartbeat clocks: the live one that paces the robot and the simulated one that replays it.

Both count robot time in integer nanoseconds, the sum of the heartbeat intervals HB_t,
so time seen by behaviors is exact and identical on the robot and on a PC.
"""

from __future__ import annotations

import time

__all__ = ["DEFAULT_PERIOD_NS", "LiveHeartbeat", "SimulatedHeartbeat"]

DEFAULT_PERIOD_NS = 30_000_000
"""The AIBO's 30 ms main cycle."""


class SimulatedHeartbeat:
    """Advances by recorded heartbeat intervals and never sleeps."""

    __slots__ = ("now_ns",)

    def __init__(self) -> None:
        self.now_ns = 0

    def advance(self, interval_ns: int) -> int:
        """Move robot time forward by one heartbeat interval and return the new robot time."""
        self.now_ns = now_ns = self.now_ns + interval_ns
        return now_ns


class LiveHeartbeat:
    """Signals each main cycle on a fixed monotonic grid (``start + k * period``) and
    measures the real interval; a cycle that overruns is counted and the clock resumes at
    the next grid point still ahead, so a slow cycle never shifts later beats."""

    def __init__(self, period_ns: int = DEFAULT_PERIOD_NS) -> None:
        if period_ns <= 0:
            raise ValueError(f"heartbeat period must be positive, got {period_ns} ns")
        self.period_ns = period_ns
        self.overruns = 0
        self.now_ns = 0
        self._start_ns: int | None = None
        self._last_ns = 0
        self._due_ns = 0

    def start(self) -> None:
        """Start the timer; the first beat is due one period from now."""
        self._start_ns = self._last_ns = time.monotonic_ns()
        self._due_ns = self._start_ns + self.period_ns
        self.now_ns = 0
        self.overruns = 0

    def wait(self) -> int:
        """Block until the next heartbeat and return the measured interval HB_t in ns."""
        if self._start_ns is None:
            self.start()
        now = time.monotonic_ns()
        if now > self._due_ns:
            self.overruns += 1
            missed = (now - self._due_ns) // self.period_ns + 1
            self._due_ns += missed * self.period_ns
        while (remaining := self._due_ns - time.monotonic_ns()) > 0:
            time.sleep(remaining / 1e9)
        beat = time.monotonic_ns()
        interval = beat - self._last_ns
        self._last_ns = beat
        self._due_ns += self.period_ns
        self.now_ns += interval
        return interval
