"""Behavior lanes of a timeline: each behavior's states over robot time, as recorded
(or as a baseline has them) and as replayed, folded to the buckets of a :class:`TimeGrid`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import NamedTuple

from beatlog.analysis.grid import TimeGrid
from beatlog.analysis.recorded import named_changes
from beatlog.log.format import EMPTY_LIST, CycleRecord, SessionHeader
from beatlog.model.behavior import BehaviorState, System
from beatlog.replay.core import CycleOutcome
from beatlog.replay.verdict import StateChange

__all__ = ["Lanes"]


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


class _Lane:
    """One behavior's intervals: closed at each state change, folded as the grid widens."""

    def __init__(self, initial: BehaviorState, grid: TimeGrid) -> None:
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


class Lanes:
    """Keeps every behavior's lane, expected and actual, from the cycles and outcomes."""

    def __init__(
        self,
        header: SessionHeader,
        system: System | None,
        path: Path,
        expected: Mapping[int, Sequence[StateChange]] | None,
        grid: TimeGrid,
    ) -> None:
        self.path = path
        self.cycle = -1
        self.time_ns = 0
        self._grid = grid
        self._catalogue = list(header.behaviors)
        self._override = expected
        recorded = header.initial_states_by_name()
        initial = {} if system is None else {n: b.state for n, b in system.behaviors.items()}
        self._names = list(initial)
        self._actual = {name: _Lane(state, grid) for name, state in initial.items()}
        self._expected = {
            name: _Lane(recorded.get(name, initial.get(name)), grid)
            for name in dict.fromkeys([*self._catalogue, *initial])
        }
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
        if override is not None and self.cycle in override:
            expected = list(override[self.cycle])
        elif record.state_changes == EMPTY_LIST:
            expected = []
        else:
            expected = named_changes(self.path, record.state_changes, self._catalogue, self.cycle)
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
