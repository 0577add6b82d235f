"""The details of a failed DTC, gathered in one more replay however many are asked for.

The verdict's replay stops at the first divergence. Reports want more: the robot-state
fields the behaviors read in the diverging cycle, the whole new trace for
re-baselining, and timelines for charts. :func:`replay_details` replays the log once
more with the replay core and feeds every consumer from the same outcomes, so a DTC
is replayed at most twice in all.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from beatlog.analysis.timeline import Timeline, TimelineCollector, close_up_window
from beatlog.analysis.trace import ReadTracker, ReplayedTrace, TraceCollector
from beatlog.log.format import CycleRecord
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import System
from beatlog.model.perception import Perception
from beatlog.replay.core import CycleOutcome, Replayer
from beatlog.replay.verdict import Divergence, DivergenceKind, StateChange

__all__ = ["Details", "replay_details"]


@dataclass(frozen=True)
class Details:
    """What one more replay of a judged log found."""

    fields_read: tuple[str, ...] = ()
    """Robot-state fields the behaviors read in the diverging cycle, in order."""
    trace: ReplayedTrace | None = None
    """The whole replayed trace, when asked for."""
    timelines: tuple[Timeline, ...] = ()
    """A close-up of the divergence (if any), then the whole session, when asked for."""


def replay_details(
    log: str | Path,
    system: System,
    divergence: Divergence | None,
    *,
    trace: bool = False,
    timelines: bool = False,
    expected: Mapping[int, Sequence[StateChange]] | None = None,
    perception: Perception | None = None,
) -> Details:
    """Replay ``log`` on a fresh ``system`` once, gathering what is asked for.

    ``divergence`` is the verdict's; the fields read are those of its cycle.
    ``expected`` stands in for the recorded state changes in the timelines (an
    approved baseline). With a ``perception`` step, each robot state is rebuilt from the
    logged samples, as the verdict's replay did. Stepping stops as soon as nothing asked
    for needs more.
    """
    diverged_at = (
        None
        if divergence is None or divergence.kind is DivergenceKind.LOG_ENDED
        else divergence.cycle
    )
    reads = ReadTracker()
    with SessionLogReader(log) as reader:
        replayer = Replayer(system, reader.header, reader.path, perception=perception)
        tracer = TraceCollector(replayer.executor.behavior_ids) if trace else None
        charts = (
            _Charts(
                TimelineCollector(reader, system, expected=expected),
                None
                if divergence is None
                else TimelineCollector(
                    reader, system, expected=expected, window_ns=close_up_window(divergence)
                ),
            )
            if timelines
            else None
        )
        cycle = -1
        for batch in reader.batches():
            for record in batch:
                cycle += 1
                needed = (
                    (tracer is not None and tracer.stopped is None)
                    or (charts is not None and charts.replaying)
                    or (diverged_at is not None and cycle <= diverged_at)
                )
                if not needed and charts is None:
                    return _details(reads, diverged_at, tracer, charts, divergence)
                outcome = None
                if needed:
                    observe = reads.stand_in if cycle == diverged_at else None
                    outcome = replayer.step(record, observe=observe)
                    if tracer is not None:
                        tracer.add(outcome)
                if charts is not None:
                    charts.add(record, outcome)
    return _details(reads, diverged_at, tracer, charts, divergence)


def _details(
    reads: ReadTracker,
    diverged_at: int | None,
    tracer: TraceCollector | None,
    charts: _Charts | None,
    divergence: Divergence | None,
) -> Details:
    return Details(
        fields_read=tuple(reads.read) if diverged_at is not None else (),
        trace=None if tracer is None else tracer.trace(),
        timelines=() if charts is None else charts.timelines(divergence),
    )


class _Charts:
    """The whole session's timeline and, for a divergence, a close-up of it."""

    def __init__(self, whole: TimelineCollector, close_up: TimelineCollector | None) -> None:
        self._whole = whole
        self._close_up = close_up

    @property
    def replaying(self) -> bool:
        return self._whole.replaying

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        self._whole.add(record, outcome)
        if self._close_up is not None and not self._close_up.done:
            self._close_up.add(record, outcome)

    def timelines(self, divergence: Divergence | None) -> tuple[Timeline, ...]:
        """The close-up first, if there is one, then the whole session; both mark
        ``divergence``."""
        whole = self._whole.timeline(divergence)
        if self._close_up is None:
            return (whole,)
        return self._close_up.timeline(divergence), whole
