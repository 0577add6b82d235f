"""Timelines for reports: when each behavior was in which state, recorded and replayed.

:func:`build_timeline` reads a session log and, given a system, replays it the way
the replay engine does, but instead of stopping at the first divergence it keeps
every cycle's expected and actual behavior state changes, and samples numeric
robot-state fields along the way. Long sessions are downsampled so a chart of a
35,000-cycle log stays small. Without a system it only reads the log: no code runs.
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import msgspec
import numpy as np
import numpy.typing as npt

from beatlog.errors import CorruptLogError, FieldError
from beatlog.log.format import (
    DECODE_ERRORS,
    EMPTY_LIST,
    CycleRecord,
    SessionHeader,
    StateChangeRecord,
)
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import BehaviorState, System
from beatlog.replay.core import CycleOutcome, Replayer
from beatlog.replay.verdict import Divergence, DivergenceKind, StateChange
from beatlog.usercode import load_system

__all__ = [
    "CLOSE_UP_NS",
    "DEFAULT_FIELDS",
    "BehaviorLane",
    "Interval",
    "Mark",
    "Signal",
    "Timeline",
    "TimelineCollector",
    "build_timeline",
]

DEFAULT_FIELDS = 4
"""How many numeric robot-state fields a timeline samples when none are named."""
CLOSE_UP_NS = 3_000_000_000
"""A report's close-up shows this much robot time either side of the first divergence."""


class Interval(NamedTuple):
    """A behavior in one state from ``start_ns`` to ``end_ns`` (robot time)."""

    start_ns: int
    end_ns: int
    state: BehaviorState
    flicker: int = 0
    """State changes folded into this interval by downsampling; ``state`` is then the last."""


class BehaviorLane(NamedTuple):
    """One behavior's states over the session: as recorded (expected) and as replayed."""

    behavior: str
    expected: tuple[Interval, ...]
    actual: tuple[Interval, ...]
    """Empty when the timeline was built without a system."""


class Signal(NamedTuple):
    """A numeric robot-state field sampled per cycle (NaN where it was not a number)."""

    field: str
    time_ns: tuple[int, ...]
    value: tuple[float, ...]


class Mark(NamedTuple):
    """The first cycle where replay differed from the expected trace."""

    cycle: int
    time_ns: int
    kind: DivergenceKind


@dataclass(frozen=True)
class Timeline:
    """Behavior activity and robot-state signals of one session, ready to draw."""

    log: Path
    cycles: int
    """Cycles of the log in this timeline's stretch of robot time."""
    start_ns: int
    """Robot time where the timeline starts: 0, or the start of a close-up."""
    end_ns: int
    """Robot time where it ends: the session's end, or the end of a close-up."""
    lanes: tuple[BehaviorLane, ...]
    signals: tuple[Signal, ...]
    replayed: bool
    """Whether a system was replayed, so lanes have actual intervals."""
    replayed_until_ns: int
    """Actual intervals end here: the session's end, or where replay could not go on."""
    divergence: Mark | None


def build_timeline(
    log: str | Path,
    system: System | str | None = None,
    *,
    fields: Sequence[str] | None = None,
    expected: Mapping[int, Sequence[StateChange]] | None = None,
    divergence: Divergence | None = None,
    max_points: int = 2000,
    window_ns: tuple[int, int] | None = None,
) -> Timeline:
    """The timeline of ``log``, replayed against ``system`` if one is given.

    ``fields`` names the robot-state fields to sample (default: the first
    :data:`DEFAULT_FIELDS` numeric ones). ``expected`` replaces the recorded state
    changes (cycle to changes, e.g. an approved baseline). ``divergence`` is the
    verdict's first divergence, marked on the chart. Intervals shorter than the
    timeline's length / ``max_points`` are folded together and signals keep the
    minimum and maximum of as many buckets, so a chart stays small. The actual lanes
    end where replay cannot go on (an exception, a random-number mismatch).
    ``window_ns`` (start, end) keeps only that stretch of robot time, for a close-up.

    :raises beatlog.errors.LogError: the log cannot be read or does not fit the system.
    :raises beatlog.errors.FieldError: a named field is missing or not a number.
    """
    if isinstance(system, str):
        system = load_system(system)
    until_ns = None if window_ns is None else window_ns[1]
    with SessionLogReader(log) as reader:
        replayer = None if system is None else Replayer(system, reader.header, reader.path)
        collector = TimelineCollector(reader, system, fields=fields, expected=expected)
        for batch in reader.batches():
            for record in batch:
                outcome = (
                    replayer.step(record) if replayer is not None and collector.replaying else None
                )
                collector.add(record, outcome)
            if until_ns is not None and collector.time_ns >= until_ns:
                break
    return collector.timeline(window_ns, divergence, max_points)


class TimelineCollector:
    """Gathers, cycle by cycle, what the timelines of any stretch of a session are cut
    from: the expected state changes from the record (or a baseline), the actual ones
    from the replay core's outcomes, and the sampled robot-state fields."""

    def __init__(
        self,
        reader: SessionLogReader,
        system: System | None,
        *,
        fields: Sequence[str] | None = None,
        expected: Mapping[int, Sequence[StateChange]] | None = None,
    ) -> None:
        self.log = reader.path
        self._lanes = _Collector(reader.header, system, reader.path, expected)
        self._sampler = _Sampler(reader.path, fields)
        self._replayed = system is not None

    @property
    def time_ns(self) -> int:
        """Robot time of the cycles added so far."""
        return self._lanes.time_ns

    @property
    def replaying(self) -> bool:
        """Whether the actual lanes still follow the replay (it has not stopped)."""
        return self._lanes.replaying

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        """Add the next recorded cycle and, when replaying, its outcome."""
        self._sampler.add(record)
        self._lanes.add(record, outcome)

    def timeline(
        self,
        window_ns: tuple[int, int] | None,
        divergence: Divergence | None,
        max_points: int = 2000,
    ) -> Timeline:
        """The timeline of the whole session, or of ``window_ns`` of it, marking
        ``divergence`` (the verdict's)."""
        lanes = self._lanes
        start, end = 0, lanes.time_ns
        if window_ns is not None:
            start, end = max(window_ns[0], 0), min(window_ns[1], end)
        resolution = (end - start) // max(max_points, 1)
        mark = (
            None
            if divergence is None
            else Mark(divergence.cycle, divergence.time_ns, divergence.kind)
        )
        return Timeline(
            log=self.log,
            cycles=self._sampler.cycles_within(start, end),
            start_ns=start,
            end_ns=end,
            lanes=lanes.lanes(start, end, resolution),
            signals=self._sampler.signals(start, end, max_points),
            replayed=self._replayed,
            replayed_until_ns=min(lanes.replayed_until_ns, end),
            divergence=mark,
        )

    def report(self, divergence: Divergence | None) -> tuple[Timeline, ...]:
        """What a report draws for one DTC: if it diverged, a close-up of
        :data:`CLOSE_UP_NS` either side of the first divergence at full detail; then
        the whole session. Both mark ``divergence``."""
        whole = self.timeline(None, divergence)
        if divergence is None:
            return (whole,)
        window = (divergence.time_ns - CLOSE_UP_NS, divergence.time_ns + CLOSE_UP_NS)
        return self.timeline(window, divergence), whole


class _LaneBuilder:
    """Closes an interval at each state change of one behavior."""

    def __init__(self, initial: BehaviorState) -> None:
        self.state = initial
        self.start_ns = 0
        self.changed = False
        self.intervals: list[Interval] = []

    def change(self, time_ns: int, change: StateChange) -> None:
        if not self.changed:  # the recorded state before the first change beats any guess
            self.state = change.before
            self.changed = True
        if time_ns > self.start_ns:
            self.intervals.append(Interval(self.start_ns, time_ns, self.state))
        self.state = change.after
        self.start_ns = time_ns

    def close(self, start_ns: int, end_ns: int, resolution_ns: int) -> tuple[Interval, ...]:
        """The intervals from ``start_ns`` to ``end_ns``, cut at both ends."""
        intervals = [*self.intervals, Interval(self.start_ns, end_ns, self.state)]
        return _coarsen(
            [
                interval._replace(start_ns=max(interval.start_ns, start_ns), end_ns=stop)
                for interval in intervals
                if (stop := min(interval.end_ns, end_ns)) > max(interval.start_ns, start_ns)
            ],
            resolution_ns,
        )


def _coarsen(intervals: Sequence[Interval], resolution_ns: int) -> tuple[Interval, ...]:
    """Fold each run of intervals shorter than ``resolution_ns`` into one flickering one."""
    folded: list[Interval] = []
    previous_short = False
    for interval in intervals:
        short = interval.end_ns - interval.start_ns < resolution_ns
        if short and previous_short:
            last = folded[-1]
            folded[-1] = Interval(last.start_ns, interval.end_ns, interval.state, last.flicker + 1)
        else:
            folded.append(interval)
        previous_short = short
    return tuple(folded)


class _Collector:
    """Replays cycles and keeps every state change, expected and actual."""

    def __init__(
        self,
        header: SessionHeader,
        system: System | None,
        path: Path,
        expected: Mapping[int, Sequence[StateChange]] | None,
    ) -> None:
        self.path = path
        self.cycle = -1
        self.time_ns = 0
        self._catalogue = list(header.behaviors)
        self._override = expected
        self._changes_decoder = msgspec.msgpack.Decoder(list[StateChangeRecord])
        self._expected: dict[str, _LaneBuilder] = {}
        self._actual: dict[str, _LaneBuilder] = {}
        recorded = header.initial_states_by_name()
        initial: dict[str, BehaviorState] = {}
        self._names: list[str] = []
        if system is not None:
            initial = {name: b.state for name, b in system.behaviors.items()}
            self._actual = {name: _LaneBuilder(state) for name, state in initial.items()}
            self._names = list(system.behaviors)
        for name in [*self._catalogue, *initial]:
            self._expected.setdefault(name, _LaneBuilder(recorded.get(name, initial.get(name))))
        self._stopped_ns: int | None = None

    @property
    def replayed_until_ns(self) -> int:
        return self.time_ns if self._stopped_ns is None else self._stopped_ns

    @property
    def replaying(self) -> bool:
        return self._stopped_ns is None

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        self.cycle += 1
        previous_ns = self.time_ns
        self.time_ns += record.heartbeat_ns
        override = self._override
        if override is not None:
            expected = list(override.get(self.cycle, ()))
        elif record.state_changes == EMPTY_LIST:
            expected = []
        else:
            expected = self._recorded(record.state_changes)
        self._add(self._expected, expected)
        if outcome is None or self._stopped_ns is not None:
            return
        if outcome.changes is None or outcome.failure is not None:
            self._stopped_ns = previous_ns  # replay cannot go on: the lanes end here
            return
        names = self._names
        self._add(
            self._actual,
            [StateChange(names[i], before, after) for i, before, after in outcome.changes],
        )

    def _add(self, lanes: dict[str, _LaneBuilder], changes: Sequence[StateChange]) -> None:
        for change in changes:
            lane = lanes.get(change.behavior)
            if lane is None:
                lane = lanes[change.behavior] = _LaneBuilder(None)
            lane.change(self.time_ns, change)

    def _recorded(self, raw: msgspec.Raw) -> list[StateChange]:
        try:
            changes = self._changes_decoder.decode(raw)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(
                self.path, f"damaged state changes in cycle {self.cycle}: {exc}"
            ) from None
        names = self._catalogue
        return [
            StateChange(names[index] if 0 <= index < len(names) else f"#{index}", before, after)
            for index, before, after in changes
        ]

    def lanes(self, start_ns: int, end_ns: int, resolution_ns: int) -> tuple[BehaviorLane, ...]:
        names = list(self._expected) + [n for n in self._actual if n not in self._expected]
        empty = _LaneBuilder(None)
        replayed_ns = min(self.replayed_until_ns, end_ns)
        return tuple(
            BehaviorLane(
                name,
                self._expected.get(name, empty).close(start_ns, end_ns, resolution_ns),
                self._actual[name].close(start_ns, replayed_ns, resolution_ns)
                if name in self._actual
                else (),
            )
            for name in names
        )


class _Sampler:
    """Samples numeric robot-state fields per cycle, read from the log without any code."""

    def __init__(self, path: Path, fields: Sequence[str] | None) -> None:
        self.path = path
        self._asked = fields
        self._fields: list[str] | None = None
        self._decoder = msgspec.msgpack.Decoder()
        self._time_ns: list[int] = []
        self._values: list[list[float]] = []
        self._now_ns = 0

    def add(self, record: CycleRecord) -> None:
        self._now_ns += record.heartbeat_ns
        try:
            state = self._decoder.decode(record.robot_state)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(
                self.path, f"damaged robot state in cycle {len(self._time_ns)}: {exc}"
            ) from None
        if not isinstance(state, dict):
            state = {}
        if self._fields is None:
            self._fields = self._choose(state)
            self._values = [[] for _ in self._fields]
        self._time_ns.append(self._now_ns)
        for name, values in zip(self._fields, self._values, strict=True):
            values.append(_number(state.get(name)))

    def _choose(self, state: dict[str, Any]) -> list[str]:
        numeric = [name for name, value in state.items() if not math.isnan(_number(value))]
        if self._asked is None:
            return numeric[:DEFAULT_FIELDS]
        known = ", ".join(numeric) or "none"
        for name in self._asked:
            if name not in state:
                raise FieldError(
                    f"{self.path}: the robot state has no field {name!r} (numeric fields: {known})"
                )
            if name not in numeric:
                raise FieldError(
                    f"{self.path}: robot-state field {name!r} is a {type(state[name]).__name__}, "
                    f"not a number (numeric fields: {known})"
                )
        return list(dict.fromkeys(self._asked))

    def cycles_within(self, start_ns: int, end_ns: int) -> int:
        """How many cycles end from ``start_ns`` to ``end_ns`` (all of them: the whole log)."""
        times = self._time_ns
        return bisect.bisect_right(times, end_ns) - bisect.bisect_left(times, start_ns)

    def signals(self, start_ns: int, end_ns: int, max_points: int) -> tuple[Signal, ...]:
        times = np.array(self._time_ns, dtype=np.int64)
        inside = (times >= start_ns) & (times <= end_ns)
        times = times[inside]
        result = []
        for name, values in zip(self._fields or (), self._values, strict=True):
            series = np.array(values, dtype=np.float64)[inside]
            keep = _extremes(series, max_points)
            result.append(Signal(name, tuple(times[keep].tolist()), tuple(series[keep].tolist())))
        return tuple(result)


def _number(value: Any) -> float:
    if isinstance(value, int | float):
        return float(value)
    return math.nan


def _extremes(series: npt.NDArray[np.float64], buckets: int) -> npt.NDArray[np.intp]:
    """Indices of each bucket's minimum and maximum, in order: a chart of them looks the same."""
    if len(series) <= 2 * buckets:
        return np.arange(len(series))
    missing = np.isnan(series)
    low = np.where(missing, np.inf, series)
    high = np.where(missing, -np.inf, series)
    edges = np.linspace(0, len(series), buckets + 1).astype(np.intp)
    keep = [
        index
        for start, end in itertools.pairwise(edges.tolist())
        for index in (
            start + int(np.argmin(low[start:end])),
            start + int(np.argmax(high[start:end])),
        )
    ]
    return np.unique(np.array(keep, dtype=np.intp))
