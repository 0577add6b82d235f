"""What a session log holds, in figures: for ``beatlog show`` and for people reading logs.

The log is streamed in bounded memory: the exact 99th percentile of the heartbeat
intervals comes from a count of each distinct interval while there are few of them,
else from a second pass.
"""

from __future__ import annotations

import heapq
import math
from collections import Counter
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import msgspec

from beatlog.errors import CorruptLogError
from beatlog.log.format import (
    DECODE_ERRORS,
    EMPTY_LIST,
    Draw,
    SessionEnd,
    SessionHeader,
    StateChangeRecord,
)
from beatlog.log.reader import LogStatus, SessionLogReader

__all__ = ["LogSummary", "summarize"]

_MAX_DISTINCT_INTERVALS = 1 << 16
"""Distinct heartbeat intervals counted in the first pass before a second is needed."""


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
    samples: dict[str, int] | None
    """Raw sensor samples logged per sensor; None when the session logged none."""
    url: str | None = None
    """The URL of the log, when it lay behind one: ``path`` is then the copy read, which
    is gone."""

    @property
    def log_name(self) -> str:
        """The log as messages name it: its URL, or its path."""
        return str(self.path) if self.url is None else self.url

    @property
    def format_version(self) -> int:
        """The log format version the session was written in."""
        return self.header.format_version


class _Sensor(msgspec.Struct, array_like=True):
    """The first field of a logged sample: which sensor it came from."""

    sensor: str


def summarize(path: str | Path) -> LogSummary:
    """Read a whole log and gather its figures; a log whose cycles read back intact but
    whose index is damaged has figures, and a status that says so."""
    changes_decoder = msgspec.msgpack.Decoder(list[StateChangeRecord])
    draws_decoder = msgspec.msgpack.Decoder(list[Draw])
    cycles = longest = late = 0
    intervals: Counter[int] | None = Counter()
    transitions = Counter[int]()
    draws = Counter[str]()
    sensors = Counter[str]()
    samples_decoder = msgspec.msgpack.Decoder(list[_Sensor])
    with SessionLogReader(path, tolerate_damaged_index=True) as reader:
        header = reader.header
        late_ns = 1.5 * header.period_ns
        for batch in reader.batches():
            beats = [cycle.heartbeat_ns for cycle in batch]
            if intervals is not None:
                intervals.update(beats)
                if len(intervals) > _MAX_DISTINCT_INTERVALS:
                    intervals = None
            slowest = max(beats)
            if slowest > late_ns:
                late += len([beat for beat in beats if beat > late_ns])
            longest = max(longest, slowest)
            try:
                for changes in [c.state_changes for c in batch if c.state_changes != EMPTY_LIST]:
                    transitions.update(
                        behavior for behavior, _, _ in changes_decoder.decode(changes)
                    )
                for numbers in [c.random_numbers for c in batch if c.random_numbers != EMPTY_LIST]:
                    draws.update(d.kind for d in draws_decoder.decode(numbers))
                if header.samples_logged:
                    for samples in [c.samples for c in batch if c.samples != EMPTY_LIST]:
                        sensors.update(s.sensor for s in samples_decoder.decode(samples))
            except DECODE_ERRORS as exc:
                where = f"cycles {cycles}-{cycles + len(batch) - 1}"
                raise CorruptLogError(reader.path, f"damaged {where}: {exc}") from None
            cycles += len(batch)
        status, end, robot_time_ns = reader.status, reader.end, reader.robot_time_ns
    names = header.behaviors
    return LogSummary(
        path=Path(path),
        header=header,
        status=status,
        end=end,
        cycles=cycles,
        robot_time_ns=robot_time_ns,
        heartbeat_mean_ms=robot_time_ns / cycles / 1e6 if cycles else 0.0,
        heartbeat_p99_ms=_p99(
            _intervals(path, cycles) if intervals is None else intervals.elements(), cycles
        )
        / 1e6,
        heartbeat_max_ms=longest / 1e6,
        late_beats=late,
        transitions={name: transitions[index] for index, name in enumerate(names)},
        random_draws=dict(sorted(draws.items())),
        samples=dict(sorted(sensors.items())) if header.samples_logged else None,
    )


def _intervals(path: str | Path, cycles: int) -> Iterator[int]:
    """The first ``cycles`` heartbeat intervals, read again."""
    with SessionLogReader(path, tolerate_damaged_index=True) as reader:
        read = 0
        for batch in reader.batches():
            for cycle in batch[: cycles - read]:
                yield cycle.heartbeat_ns
            read += len(batch)
            if read >= cycles:
                return


def _p99(intervals: Iterable[int], count: int) -> int:
    """The nearest-rank 99th percentile of ``count`` intervals, keeping only the largest
    1 % in memory."""
    if count == 0:
        return 0
    return heapq.nlargest(count - math.ceil(0.99 * count) + 1, intervals)[-1]
