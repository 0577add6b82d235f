"""The details of a failed DTC, gathered in one more replay however many are asked for:
the robot-state fields the behaviors read in the diverging cycle, the whole new trace
for re-baselining, and timelines for charts (the verdict's replay stops at the first
divergence). Given the :class:`~beatlog.log.recording.Recording` the verdict's replay
kept, the file is not read again.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from beatlog.analysis.timeline import CLOSE_UP_NS, Timeline, TimelineCollector
from beatlog.analysis.trace import ReplayedTrace, TraceCollector
from beatlog.log.recording import LogSource
from beatlog.model.behavior import System
from beatlog.model.perception import Perception
from beatlog.model.setup import SystemFactory
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.session import FieldsRead, ReplaySession
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
    log: LogSource,
    system: System | SystemFactory | str,
    divergence: Divergence | None,
    *,
    trace: bool = False,
    timelines: bool = False,
    expected: Mapping[int, Sequence[StateChange]] | None = None,
    perception: Perception | None = None,
    match_draws: bool = False,
    rename: Callable[[str], str] = str,
    migration: StateMigration | None = None,
    fresh_from: int = 0,
) -> Details:
    """Replay ``log`` once on a fresh ``system`` (or one its factory or reference builds),
    gathering what is asked for, until nothing asked for needs more.

    ``divergence`` is the verdict's (the fields read are those of its cycle);
    ``expected`` stands in for the recorded state changes in the timelines (an approved
    baseline). ``perception``, ``match_draws``, ``rename``, ``migration`` and ``fresh_from``
    replay as the verdict's replay did (:class:`~beatlog.replay.session.ReplaySession`).
    """
    diverged_at = (
        None
        if divergence is None or divergence.kind is DivergenceKind.LOG_ENDED
        else divergence.cycle
    )
    reads = None if diverged_at is None else FieldsRead(diverged_at)
    with ReplaySession(
        log,
        system,
        perception=perception,
        match_draws=match_draws,
        rename=rename,
        migration=migration,
        fresh_from=fresh_from,
    ) as session:
        assert session.replayer is not None  # a session with a system replays
        built = session.replayer.system
        tracer = TraceCollector(session.replayer, rename) if trace else None
        charts: list[TimelineCollector] = []
        if timelines:
            if divergence is not None:  # the close-up first
                window = (divergence.time_ns - CLOSE_UP_NS, divergence.time_ns + CLOSE_UP_NS)
                charts.append(
                    TimelineCollector(session.reader, built, expected=expected, window_ns=window)
                )
            charts.append(TimelineCollector(session.reader, built, expected=expected))
        session.run([*([tracer] if tracer else []), *charts], fields_read=reads)
    return Details(
        fields_read=() if reads is None else reads.fields,
        trace=None if tracer is None else tracer.trace(),
        timelines=tuple(chart.timeline(divergence) for chart in charts),
    )
