"""Timelines for charts: when each behavior was in which state, recorded and replayed,
and a few numeric robot-state fields, kept in memory that does not grow with the session.

Robot time is cut into buckets (:class:`~beatlog.analysis.grid.TimeGrid`) that widen as
the session outgrows them; lanes (:mod:`~beatlog.analysis.lanes`) fold state changes
shorter than a bucket into one flickering interval, and signals
(:mod:`~beatlog.analysis.signals`) keep each bucket's minimum and maximum.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

from beatlog.analysis.grid import TimeGrid
from beatlog.analysis.lanes import BehaviorLane, Interval, Lanes
from beatlog.analysis.signals import DEFAULT_FIELDS, Sampler, Signal
from beatlog.log.format import CycleRecord
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import System
from beatlog.model.setup import SystemFactory
from beatlog.replay.core import CycleOutcome
from beatlog.replay.session import ReplaySession
from beatlog.replay.verdict import Divergence, DivergenceKind, StateChange

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
]

CLOSE_UP_NS = 3_000_000_000
"""A report's close-up shows this much robot time either side of the first divergence."""
BUCKETS = 2000
"""How many stretches of robot time a timeline keeps, whatever the session's length."""


class Mark(NamedTuple):
    """The first cycle where replay differed from the expected trace."""

    cycle: int
    time_ns: int
    kind: DivergenceKind

    def describe(self) -> str:
        """How a chart marks it: ``first divergence: cycle 21, t = 0.660 s (outputs)``."""
        return f"first divergence: cycle {self.cycle}, t = {self.time_ns / 1e9:.3f} s ({self.kind})"


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

    @property
    def title(self) -> str:
        """A chart's title where none is given."""
        return f"{self.log.name}: {self.cycles} cycles"

    def states(self) -> list[str]:
        """The states of the lanes (as charts name them), in order of first appearance."""
        intervals = (i for lane in self.lanes for i in (*lane.expected, *lane.actual))
        return list(dict.fromkeys(str(interval.state) for interval in intervals))

    def rows(self) -> list[tuple[str, tuple[Interval, ...], bool]]:
        """A chart's rows, top to bottom: each lane as recorded, then as replayed (when
        replayed); each with its label, its intervals and whether it is the replayed one."""
        rows = []
        for lane in self.lanes:
            rows.append((f"{lane.behavior}: recorded", lane.expected, False))
            if self.replayed:
                rows.append(("replayed", lane.actual, True))
        return rows


def build_timeline(
    log: str | Path,
    system: System | SystemFactory | str | None = None,
    *,
    fields: Sequence[str] | None = None,
    expected: Mapping[int, Sequence[StateChange]] | None = None,
    divergence: Divergence | None = None,
    max_points: int = BUCKETS,
    window_ns: tuple[int, int] | None = None,
) -> Timeline:
    """The timeline of ``log`` (read once, for ``beatlog plot``), replayed against
    ``system`` if one is given; without one no code runs.

    ``fields`` names the robot-state fields to draw (default: the first
    :data:`DEFAULT_FIELDS` numeric ones); ``expected`` stands in for the recorded state
    changes in the cycles it holds (an approved baseline's); ``divergence``, the
    verdict's, is marked. Robot time is kept in ``max_points`` buckets; ``window_ns``
    (start, end) keeps only that stretch, for a close-up. The replayed lanes end where
    replay cannot go on.

    :raises beatlog.errors.LogError: the log cannot be read or does not fit the system.
    :raises beatlog.errors.FieldError: a named field is missing or not a number.
    """
    with ReplaySession(log, system) as session:
        replayer = session.replayer
        collector = TimelineCollector(
            session.reader,
            None if replayer is None else replayer.system,
            fields=fields,
            expected=expected,
            buckets=max_points,
            window_ns=window_ns,
        )
        session.run([collector])
    return collector.timeline(divergence)


class TimelineCollector:
    """Gathers, cycle by cycle, the timeline of a session or of ``window_ns`` of it, from
    the records and (when replaying) the replay core's outcomes. It holds at most
    ``buckets`` per signal and ``2 * buckets + 1`` intervals per lane, however long the
    session; a window's buckets are fixed by its span."""

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
        self.grid = TimeGrid(start, end, max(buckets, 1))
        self._lanes = Lanes(reader.header, system, reader.path, expected, self.grid)
        self._sampler = Sampler(reader.path, fields, self.grid)
        self._replayed = system is not None

    @property
    def replaying(self) -> bool:
        """Whether the actual lanes still follow the replay (it has not stopped)."""
        return self._lanes.replaying

    @property
    def reading(self) -> bool:
        """Whether more cycles change the timeline: those added so far do not yet reach
        past the window."""
        return self.grid.end_ns is None or self._lanes.time_ns < self.grid.end_ns

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
