"""What a session log holds, in figures: for ``beatlog show`` and for people reading logs.

The log is streamed in constant memory, twice: once for the counts, then once more for
the exact 99th percentile of the heartbeat intervals, which needs only the largest 1 %.
"""

from __future__ import annotations

import heapq
import math
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import msgspec

from beatlog.errors import CorruptLogError
from beatlog.log.format import DECODE_ERRORS, EMPTY_LIST, SessionEnd, SessionHeader
from beatlog.log.reader import LogStatus, SessionLogReader

__all__ = ["LogSummary", "summarize"]


@dataclass(frozen=True)
class LogSummary:
    """Figures of one session log."""

    path: Path
    header: SessionHeader
    status: LogStatus
    end: SessionEnd | None
    cycles: int
    robot_time_ns: int
    heartbeat_mean_ms: float
    heartbeat_p99_ms: float
    """The nearest-rank 99th percentile: 99 % of the intervals are no longer."""
    heartbeat_max_ms: float
    late_beats: int
    """Heartbeat intervals longer than 1.5 periods."""
    transitions: dict[str, int]
    """State changes per behavior, in catalogue order."""
    random_draws: dict[str, int]
    """Random numbers drawn per kind."""

    @property
    def format_version(self) -> int:
        """The log format version the session was written in."""
        return self.header.format_version


class _Change(msgspec.Struct, array_like=True):
    behavior: int


class _Draw(msgspec.Struct, array_like=True):
    actor: int
    kind: str


def summarize(path: str | Path) -> LogSummary:
    """Read a whole log and gather its figures."""
    changes_decoder = msgspec.msgpack.Decoder(list[_Change])
    draws_decoder = msgspec.msgpack.Decoder(list[_Draw])
    cycles = robot_time_ns = longest = late = 0
    transitions = Counter[int]()
    draws = Counter[str]()
    with SessionLogReader(path) as reader:
        header = reader.header
        late_ns = 1.5 * header.period_ns
        for batch in reader.batches():
            for cycle in batch:
                interval = cycle.heartbeat_ns
                robot_time_ns += interval
                longest = max(longest, interval)
                late += interval > late_ns
                try:
                    if cycle.state_changes != EMPTY_LIST:
                        transitions.update(
                            c.behavior for c in changes_decoder.decode(cycle.state_changes)
                        )
                    if cycle.random_numbers != EMPTY_LIST:
                        draws.update(d.kind for d in draws_decoder.decode(cycle.random_numbers))
                except DECODE_ERRORS as exc:
                    raise CorruptLogError(reader.path, f"damaged cycle {cycles}: {exc}") from None
                cycles += 1
        status, end = reader.status, reader.end
    names = header.behaviors
    return LogSummary(
        path=Path(path),
        header=header,
        status=status,
        end=end,
        cycles=cycles,
        robot_time_ns=robot_time_ns,
        heartbeat_mean_ms=robot_time_ns / cycles / 1e6 if cycles else 0.0,
        heartbeat_p99_ms=_p99(_intervals(path, cycles), cycles) / 1e6,
        heartbeat_max_ms=longest / 1e6,
        late_beats=late,
        transitions={name: transitions[index] for index, name in enumerate(names)},
        random_draws=dict(sorted(draws.items())),
    )


def _intervals(path: str | Path, cycles: int) -> Iterator[int]:
    """The first ``cycles`` heartbeat intervals, read again."""
    with SessionLogReader(path) as reader:
        read = 0
        for batch in reader.batches():
            for cycle in batch[: cycles - read]:
                yield cycle.heartbeat_ns
            read += len(batch)
            if read >= cycles:
                return


def _p99(intervals: Iterator[int], count: int) -> int:
    """The nearest-rank 99th percentile, keeping only the largest 1 % in memory."""
    if count == 0:
        return 0
    largest = heapq.nlargest(count - math.ceil(0.99 * count) + 1, intervals)
    return largest[-1]
