"""Timelines for reports: when each behavior was in which state, recorded and replayed.

A :class:`TimelineCollector` is fed a session's cycles one by one (with the replay
core's outcomes, when a system is replayed) and keeps, in memory that does not grow
with the session, what a chart of it needs: every behavior's states as recorded (or as
an approved baseline has them) and as replayed, and the minimum and maximum of a few
numeric robot-state fields. Robot time is cut into a fixed number of buckets; when the
session outgrows them, neighbouring buckets are merged and each bucket covers twice
as long, and state changes shorter than a bucket are folded into one flickering
interval. A suite run feeds a collector from the verdict's own replay;
:func:`build_timeline` reads a log once for ``beatlog plot``. Without a system only
the log is read: no code runs.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

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
from beatlog.replay.core import CycleOutcome
from beatlog.replay.session import ReplaySession
from beatlog.replay.verdict import Divergence, DivergenceKind, StateChange
from beatlog.usercode import load_system

__all__ = [
    "BUCKETS",
    "CLOSE_UP_NS",
    "DEFAULT_FIELDS",
    "BehaviorLane",
    "Interval",
    "Mark",
    "Signal",
    "Timeline",
    "TimelineCollector",
    "build_timeline",
    "close_up_window",
]

DEFAULT_FIELDS = 4
"""How many numeric robot-state fields a timeline samples when none are named."""
CLOSE_UP_NS = 3_000_000_000
"""A report's close-up shows this much robot time either side of the first divergence."""
BUCKETS = 2000
"""How many stretches of robot time a timeline keeps, whatever the session's length."""


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
    """A numeric robot-state field: each bucket's minimum and maximum, in time order."""

    field: str
    time_ns: tuple[int, ...]
    value: tuple[float, ...]
    flag: bool = False
    """Whether the field is a boolean, drawn as 0 (False) and 1 (True)."""


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

    def rows(self) -> list[tuple[str, tuple[Interval, ...], bool]]:
        """A chart's rows, top to bottom: each lane as recorded, then as replayed (when
        replayed); each with its label, its intervals and whether it is the replayed one."""
        rows = []
        for lane in self.lanes:
            rows.append((f"{lane.behavior}: recorded", lane.expected, False))
            if self.replayed:
                rows.append(("replayed", lane.actual, True))
        return rows


def close_up_window(divergence: Divergence) -> tuple[int, int]:
    """The robot time a report's close-up shows: :data:`CLOSE_UP_NS` either side of
    the first divergence."""
    return divergence.time_ns - CLOSE_UP_NS, divergence.time_ns + CLOSE_UP_NS


def build_timeline(
    log: str | Path,
    system: System | str | None = None,
    *,
    fields: Sequence[str] | None = None,
    expected: Mapping[int, Sequence[StateChange]] | None = None,
    divergence: Divergence | None = None,
    max_points: int = BUCKETS,
    window_ns: tuple[int, int] | None = None,
) -> Timeline:
    """The timeline of ``log``, replayed against ``system`` if one is given.

    ``fields`` names the robot-state fields to sample (default: the first
    :data:`DEFAULT_FIELDS` numeric ones). ``expected`` replaces the recorded state
    changes (cycle to changes, e.g. an approved baseline). ``divergence`` is the
    verdict's first divergence, marked on the chart. Robot time is kept in
    ``max_points`` buckets (see :class:`TimelineCollector`), so a chart stays small.
    The actual lanes end where replay cannot go on (an exception, a random-number
    mismatch). ``window_ns`` (start, end) keeps only that stretch of robot time, for a
    close-up.

    :raises beatlog.errors.LogError: the log cannot be read or does not fit the system.
    :raises beatlog.errors.FieldError: a named field is missing or not a number.
    """
    if isinstance(system, str):
        system = load_system(system)
    with ReplaySession(log, system) as session:
        collector = TimelineCollector(
            session.reader,
            system,
            fields=fields,
            expected=expected,
            buckets=max_points,
            window_ns=window_ns,
        )
        session.run([collector])
    return collector.timeline(divergence)


class TimelineCollector:
    """Gathers, cycle by cycle, the timeline of a session or of ``window_ns`` of it: the
    expected state changes from the record (or ``expected``, a baseline), the actual
    ones from the replay core's outcomes, and the numeric robot-state fields.

    Its memory is bounded by ``buckets``, not by the session's length: robot time is
    cut into at most that many buckets, which double in length (neighbours merged)
    whenever the session outgrows them; a signal keeps each bucket's minimum and
    maximum, and a lane folds runs of intervals shorter than a bucket into one
    flickering interval, so it holds at most ``2 * buckets + 1`` intervals. A window
    (a close-up) has its bucket length fixed by its span from the start.
    """

    def __init__(
        self,
        reader: SessionLogReader,
        system: System | None,
        *,
        fields: Sequence[str] | None = None,
        expected: Mapping[int, Sequence[StateChange]] | None = None,
        buckets: int = BUCKETS,
        window_ns: tuple[int, int] | None = None,
    ) -> None:
        self.log = reader.path
        start, end = (0, None) if window_ns is None else (max(window_ns[0], 0), window_ns[1])
        self.grid = _Grid(start, end, max(buckets, 1))
        self._lanes = _Lanes(reader.header, system, reader.path, expected, self.grid)
        self._sampler = _Sampler(reader.path, fields, self.grid)
        self._replayed = system is not None

    @property
    def time_ns(self) -> int:
        """Robot time of the cycles added so far."""
        return self._lanes.time_ns

    @property
    def replaying(self) -> bool:
        """Whether the actual lanes still follow the replay (it has not stopped)."""
        return self._lanes.replaying

    @property
    def done(self) -> bool:
        """Whether the cycles added so far reach past the window: more change nothing."""
        return self.grid.end_ns is not None and self.time_ns >= self.grid.end_ns

    @property
    def reading(self) -> bool:
        """Whether more cycles change the timeline."""
        return not self.done

    @property
    def held(self) -> int:
        """How many buckets and intervals it holds: at most ``buckets`` per signal and
        ``2 * buckets + 1`` per lane, however many cycles were added."""
        return self._sampler.held + self._lanes.held

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        """Add the next recorded cycle and, when replaying, its outcome."""
        time_ns = self._lanes.time_ns + record.heartbeat_ns
        self.grid.reach(time_ns)
        self._sampler.add(record, time_ns)
        self._lanes.add(record, outcome)

    def observe(self, outcome: CycleOutcome) -> None:
        """Add the next cycle from its outcome, as the verdict's replay hands it over."""
        self.add(outcome.record, outcome)

    def timeline(self, divergence: Divergence | None) -> Timeline:
        """The timeline of the cycles added so far, marking ``divergence`` (the verdict's)."""
        lanes = self._lanes
        start = self.grid.start_ns
        end = lanes.time_ns if self.grid.end_ns is None else min(self.grid.end_ns, lanes.time_ns)
        mark = (
            None
            if divergence is None
            else Mark(divergence.cycle, divergence.time_ns, divergence.kind)
        )
        return Timeline(
            log=self.log,
            cycles=self._sampler.cycles,
            start_ns=start,
            end_ns=end,
            lanes=lanes.lanes(end),
            signals=self._sampler.signals(),
            replayed=self._replayed,
            replayed_until_ns=min(lanes.replayed_until_ns, end),
            divergence=mark,
        )


class _Grid:
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


class _Lane:
    """One behavior's intervals: closed at each state change, folded as the grid widens."""

    def __init__(self, initial: BehaviorState, grid: _Grid) -> None:
        self.state = initial
        self.start_ns = 0
        self.changed = False
        self.intervals: list[Interval] = []
        self._grid = grid
        self._short = False

    def change(self, time_ns: int, change: StateChange) -> None:
        if not self.changed:  # the recorded state before the first change beats any guess
            self.state = change.before
            self.changed = True
        if time_ns > self.start_ns:
            self._keep(Interval(self.start_ns, time_ns, self.state))
        self.state = change.after
        self.start_ns = time_ns

    def _keep(self, interval: Interval) -> None:
        """Keep the part of ``interval`` within the grid, folded into a short run before it."""
        grid = self._grid
        start = max(interval.start_ns, grid.start_ns)
        end = interval.end_ns if grid.end_ns is None else min(interval.end_ns, grid.end_ns)
        if end <= start:
            return
        short = end - start < grid.width_ns
        if short and self._short:
            last = self.intervals[-1]
            self.intervals[-1] = Interval(
                last.start_ns, end, interval.state, last.flicker + interval.flicker + 1
            )
        else:
            self.intervals.append(interval._replace(start_ns=start, end_ns=end))
        self._short = short

    def refold(self) -> None:
        """Fold again after the grid widened: more intervals are short now."""
        intervals, self.intervals, self._short = self.intervals, [], False
        for interval in intervals:
            self._keep(interval)
        if intervals and intervals[-1].flicker:
            self._short = True

    def close(self, end_ns: int) -> tuple[Interval, ...]:
        """The intervals up to ``end_ns``, the current one included."""
        kept, short = list(self.intervals), self._short
        self._keep(Interval(self.start_ns, end_ns, self.state))
        closed = tuple(self.intervals)
        self.intervals, self._short = kept, short
        return closed


class _Lanes:
    """Keeps every behavior's lane, expected and actual, from the cycles and outcomes."""

    def __init__(
        self,
        header: SessionHeader,
        system: System | None,
        path: Path,
        expected: Mapping[int, Sequence[StateChange]] | None,
        grid: _Grid,
    ) -> None:
        self.path = path
        self.cycle = -1
        self.time_ns = 0
        self._grid = grid
        self._catalogue = list(header.behaviors)
        self._override = expected
        self._changes_decoder = msgspec.msgpack.Decoder(list[StateChangeRecord])
        self._expected: dict[str, _Lane] = {}
        self._actual: dict[str, _Lane] = {}
        recorded = header.initial_states_by_name()
        initial: dict[str, BehaviorState] = {}
        self._names: list[str] = []
        if system is not None:
            initial = {name: b.state for name, b in system.behaviors.items()}
            self._actual = {name: _Lane(state, grid) for name, state in initial.items()}
            self._names = list(system.behaviors)
        for name in [*self._catalogue, *initial]:
            if name not in self._expected:
                self._expected[name] = _Lane(recorded.get(name, initial.get(name)), grid)
        self._stopped_ns: int | None = None
        grid.on_widen.append(self._refold)

    def _refold(self, factor: int) -> None:
        for lane in (*self._expected.values(), *self._actual.values()):
            lane.refold()

    @property
    def replayed_until_ns(self) -> int:
        return self.time_ns if self._stopped_ns is None else self._stopped_ns

    @property
    def held(self) -> int:
        return sum(
            len(lane.intervals) for lane in (*self._expected.values(), *self._actual.values())
        )

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
        if expected:
            self._add(self._expected, expected)
        if outcome is None or self._stopped_ns is not None:
            return
        if outcome.changes is None or outcome.failure is not None:
            self._stopped_ns = previous_ns  # replay cannot go on: the lanes end here
            return
        if outcome.changes:
            names = self._names
            self._add(
                self._actual,
                [StateChange(names[i], before, after) for i, before, after in outcome.changes],
            )

    def _add(self, lanes: dict[str, _Lane], changes: Sequence[StateChange]) -> None:
        for change in changes:
            lane = lanes.get(change.behavior)
            if lane is None:
                lane = lanes[change.behavior] = _Lane(None, self._grid)
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

    def lanes(self, end_ns: int) -> tuple[BehaviorLane, ...]:
        names = list(self._expected) + [n for n in self._actual if n not in self._expected]
        empty = _Lane(None, self._grid)
        replayed_ns = min(self.replayed_until_ns, end_ns)
        return tuple(
            BehaviorLane(
                name,
                self._expected.get(name, empty).close(end_ns),
                self._actual[name].close(replayed_ns) if name in self._actual else (),
            )
            for name in names
        )


class _Buckets:
    """One signal's minimum and maximum (with their robot times) in each bucket."""

    def __init__(self, grid: _Grid) -> None:
        count = grid.count
        self.low = [float("inf")] * count
        self.low_ns = [0] * count
        self.high = [float("-inf")] * count
        self.high_ns = [0] * count
        self._used = 0
        """Buckets up to here may hold values: those past it need no merging."""

    def add(self, index: int, time_ns: int, value: float) -> None:
        if index >= self._used:
            self._used = index + 1
        if value < self.low[index]:
            self.low[index] = value
            self.low_ns[index] = time_ns
        if value > self.high[index]:
            self.high[index] = value
            self.high_ns[index] = time_ns

    def merge(self, factor: int) -> None:
        """Merge each run of ``factor`` neighbours into one: the buckets grew as long."""
        count = self._used
        self._used = -(-count // factor)
        for target in range(count):
            low, low_ns, high, high_ns = float("inf"), 0, float("-inf"), 0
            for source in range(target * factor, min((target + 1) * factor, count)):
                if self.low[source] < low:
                    low, low_ns = self.low[source], self.low_ns[source]
                if self.high[source] > high:
                    high, high_ns = self.high[source], self.high_ns[source]
            self.low[target], self.low_ns[target] = low, low_ns
            self.high[target], self.high_ns[target] = high, high_ns

    def points(self) -> list[tuple[int, float]]:
        """Each bucket's minimum and maximum, in time order, each point once."""
        points: list[tuple[int, float]] = []
        for low, low_ns, high, high_ns in zip(
            self.low, self.low_ns, self.high, self.high_ns, strict=True
        ):
            if low > high:  # no number in this bucket
                continue
            pair = (
                [(low_ns, low), (high_ns, high)]
                if low_ns <= high_ns
                else [(high_ns, high), (low_ns, low)]
            )
            points.extend(pair if pair[0] != pair[1] else pair[:1])
        return points


class _Sampler:
    """Keeps numeric robot-state fields in buckets, read from the log without any code."""

    def __init__(self, path: Path, fields: Sequence[str] | None, grid: _Grid) -> None:
        self.path = path
        self.cycles = 0
        self._asked = fields
        self._grid = grid
        self._fields: list[str] | None = None
        self._flags: list[bool] = []
        self._buckets: list[_Buckets] = []
        self._decode: Any = msgspec.msgpack.Decoder().decode
        self._seen = 0

    @property
    def held(self) -> int:
        return sum(len(buckets.low) for buckets in self._buckets)

    def add(self, record: CycleRecord, time_ns: int) -> None:
        if self._fields is None:
            self._start(self._decoded(record))
        if not self._grid.contains(time_ns):
            self._seen += 1
            return
        self.cycles += 1
        self._seen += 1
        if not self._buckets:
            return
        values = msgspec.structs.astuple(self._decoded(record))
        index = self._grid.index(time_ns)
        for buckets, value in zip(self._buckets, values, strict=True):
            if isinstance(value, int | float):
                buckets.add(index, time_ns, float(value))

    def _decoded(self, record: CycleRecord) -> Any:
        try:
            return self._decode(record.robot_state)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(
                self.path, f"damaged robot state in cycle {self._seen}: {exc}"
            ) from None

    def _start(self, state: Any) -> None:
        """Choose the fields from the first robot state; decode just those from now on."""
        if not isinstance(state, dict):
            state = {}
        fields = self._fields = self._choose(state)
        self._flags = [isinstance(state[name], bool) for name in fields]
        self._buckets = [_Buckets(self._grid) for _ in fields]
        self._grid.on_widen.extend(buckets.merge for buckets in self._buckets)
        sampled = msgspec.defstruct(
            "Sampled",
            [(f"f{index}", Any, None) for index in range(len(fields))],
            rename={f"f{index}": name for index, name in enumerate(fields)},
        )
        self._decode = msgspec.msgpack.Decoder(sampled).decode

    def _choose(self, state: dict[str, Any]) -> list[str]:
        numeric = [name for name, value in state.items() if isinstance(value, int | float)]
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

    def signals(self) -> tuple[Signal, ...]:
        result = []
        for name, flag, buckets in zip(self._fields or (), self._flags, self._buckets, strict=True):
            points = buckets.points()
            result.append(
                Signal(
                    name,
                    tuple(time_ns for time_ns, _ in points),
                    tuple(value for _, value in points),
                    flag,
                )
            )
        return tuple(result)
