"""Robot time cut into a fixed number of buckets, which widen as a session outgrows them.

A timeline keeps memory that does not grow with the session (:mod:`beatlog.analysis.timeline`):
its lanes and signals are kept per bucket, and told when the buckets widen.
"""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["TimeGrid"]


class TimeGrid:
    """Robot time from ``start_ns`` cut into ``count`` buckets of ``width_ns`` each.

    Without an end the width doubles (or more) whenever a cycle falls past the last
    bucket, and whoever keeps buckets is told by how much, to merge them.
    """

    def __init__(self, start_ns: int, end_ns: int | None, count: int) -> None:
        self.start_ns = start_ns
        self.end_ns = end_ns
        self.count = count
        self.width_ns = 0 if end_ns is None else max(-(-(end_ns - start_ns) // count), 1)
        """0 until the first cycle, without an end."""
        self.on_widen: list[Callable[[int], None]] = []
        """Called with the factor the width grew by."""

    def contains(self, time_ns: int) -> bool:
        return self.start_ns <= time_ns and (self.end_ns is None or time_ns <= self.end_ns)

    def index(self, time_ns: int) -> int:
        return min((time_ns - self.start_ns) // self.width_ns, self.count - 1)

    def reach(self, time_ns: int) -> None:
        """Widen the buckets until ``time_ns`` falls in one of them; the first cycle sets
        the width (a heartbeat), so a session shorter than ``count`` cycles keeps each."""
        if self.end_ns is not None:
            return
        if self.width_ns == 0:
            self.width_ns = max(time_ns - self.start_ns, 1)
        factor = 1
        while time_ns - self.start_ns >= self.count * self.width_ns * factor:
            factor *= 2
        if factor > 1:
            self.width_ns *= factor
            for widen in self.on_widen:
                widen(factor)
