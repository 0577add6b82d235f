"""Whole-session traces of behavior state changes and outputs: recorded and replayed.

Replay stops at the first divergence; re-baselining an intended change and proposing
a rename need the whole trace instead, so these walk every cycle of a log. Outputs are
traced compactly: a field appears only in the cycles where its value changes.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable, Collection
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from beatlog.analysis.recorded import named_changes, read_changes
from beatlog.log.format import EMPTY_LIST, EMPTY_MAP, CycleRecord, payload_encoder
from beatlog.log.payload import decode_outputs, decode_part
from beatlog.log.reader import SessionLogReader
from beatlog.log.recording import LogSource
from beatlog.model.behavior import System
from beatlog.replay.approved_state_lines import state_digest
from beatlog.replay.approved_states import ApprovedStates, RebuiltState, rebuilt_otherwise
from beatlog.replay.baseline import (
    Baseline,
    OutputTracker,
    TracedOutput,
    TracedStateChange,
)
from beatlog.replay.compare import WHOLE_STATE, state_fields
from beatlog.replay.core import CycleOutcome, Replayer
from beatlog.replay.departures import DepartureCollector, apply_outputs, hold
from beatlog.replay.draws import DrawMadeOtherwise, approved_draws
from beatlog.replay.session import ReplaySession
from beatlog.replay.verdict import StateChange

__all__ = [
    "ReplayedTrace",
    "TraceCollector",
    "WholeTrace",
    "recorded_outputs",
    "recorded_states",
    "recorded_trace",
    "replayed_trace",
    "whole_trace",
]


@dataclass(frozen=True)
class ReplayedTrace:
    """The state changes and outputs a system makes over a whole session log."""

    changes: tuple[TracedStateChange, ...]
    cycles: int
    """Cycles replayed."""
    stopped: str | None
    """Why replay stopped before the end of the log (the behaviors raised or drew
    random numbers the log does not have), or None when it replayed every cycle."""
    outputs: tuple[TracedOutput, ...] = ()
    """The outputs, as the cycles where a field changed value."""
    baseline: Baseline = field(default_factory=lambda: Baseline(()))
    """This trace as a baseline holds it: where its state changes and outputs depart
    from the recording's; in sensor-level replay, the robot states perception rebuilt
    otherwise than recorded, approved by digest; in replay matching draws, the draws
    made otherwise than recorded."""

    @property
    def open_loop(self) -> tuple[int, int] | None:
        """The first cycle (and its robot time) whose state changes or outputs differ
        from the recording's."""
        return self.baseline.open_loop


class WholeTrace(NamedTuple):
    """A session's state changes and outputs in every cycle, as an approved baseline
    (or the recording) has them, for review: ``baseline`` is the rest it approves
    (robot-state pins, draws, where it goes open loop)."""

    changes: tuple[TracedStateChange, ...]
    outputs: tuple[TracedOutput, ...]
    baseline: Baseline


def recorded_trace(log: LogSource) -> list[TracedStateChange]:
    """Every state change the log recorded, named by the log's behavior catalogue."""
    return read_changes(log).changes


def recorded_outputs(log: LogSource) -> list[TracedOutput]:
    """The outputs the log recorded, as the cycles where a field changed value."""
    return list(whole_trace(None, log).outputs)


def whole_trace(
    baseline: Baseline | None, log: LogSource, rename: Callable[[str], str] = str
) -> WholeTrace:
    """What replay judges ``log`` against, as a whole trace: the departures of its
    approved ``baseline`` applied to what the log recorded, or (None) the recording's
    own state changes and outputs; behaviors are named as ``rename`` names them now."""
    baseline = Baseline(()) if baseline is None else baseline
    override = baseline.changes_override() or {}
    lines = itertools.groupby(baseline.outputs, key=lambda o: o.cycle)
    line = next(lines, None)
    held: dict[str, Any] = {}
    changes: list[TracedStateChange] = []
    outputs: list[TracedOutput] = []
    tracker = OutputTracker()
    time_ns = 0
    with SessionLogReader(log) as reader:
        path, names = reader.path, reader.header.behaviors
        for cycle, record in enumerate(reader.cycles()):
            time_ns += record.heartbeat_ns
            if cycle in override:
                changes.extend(TracedStateChange(cycle, time_ns, c) for c in override[cycle])
            elif record.state_changes != EMPTY_LIST:
                recorded = named_changes(path, record.state_changes, names, cycle)
                changes.extend(
                    TracedStateChange(cycle, time_ns, c._replace(behavior=rename(c.behavior)))
                    for c in recorded
                )
            if line is not None and line[0] == cycle:
                hold(held, line[1])
                line = next(lines, None)
            values = (
                {}
                if record.outputs == EMPTY_MAP
                else decode_part(path, record.outputs, decode_outputs, "outputs", cycle)
            )
            outputs.extend(tracker.observe(cycle, time_ns, apply_outputs(values, held)))
    return WholeTrace(tuple(changes), tuple(outputs), baseline)


def recorded_states(log: str | Path, cycles: Collection[int]) -> dict[int, dict[str, Any]]:
    """The robot states the log recorded in ``cycles``, as fields (see
    :func:`~beatlog.replay.compare.state_fields`); read without the system."""
    found: dict[int, dict[str, Any]] = {}
    if not cycles:
        return found
    last = max(cycles)
    with SessionLogReader(log) as reader:
        for cycle, record in enumerate(reader.cycles()):
            if cycle > last:
                break
            if cycle in cycles:
                state = decode_part(
                    reader.path, record.robot_state, msgspec.msgpack.decode, "robot state", cycle
                )
                found[cycle] = state if isinstance(state, dict) else {WHOLE_STATE: state}
    return found


def replayed_trace(
    log: str | Path,
    system: System,
    *,
    match_draws: bool = False,
    rename: Callable[[str], str] = str,
) -> ReplayedTrace:
    """Replay every cycle of ``log`` on ``system`` and collect its state changes.

    Replay uses the recording's heartbeats, robot states and random numbers; it stops
    early when the behaviors raise or, unless ``match_draws``, draw random numbers the log
    does not have (``rename`` maps a recorded behavior's name to its name now).
    """
    with ReplaySession(log, system, match_draws=match_draws, rename=rename) as session:
        assert session.replayer is not None  # a session with a system replays
        tracer = TraceCollector(session.replayer, rename)
        session.run([tracer])
    return tracer.trace()


class TraceCollector:
    """Gathers a whole-session trace from the replay core's outcomes, up to the cycle
    where replay cannot go on (an exception, a random-number problem: the replayer's
    :meth:`~beatlog.replay.core.Replayer.stop`)."""

    def __init__(self, replayer: Replayer, rename: Callable[[str], str] = str) -> None:
        self._names = replayer.executor.behavior_ids
        self._stop = replayer.stop
        self._encode = payload_encoder().encode
        self._departures = DepartureCollector(
            self._names, [rename(name) for name in replayer.header.behaviors]
        )
        self._changes: list[TracedStateChange] = []
        self._outputs: list[TracedOutput] = []
        self._states: list[RebuiltState] = []
        self._draws: list[tuple[int, DrawMadeOtherwise]] = []
        self._tracker = OutputTracker()
        self._cycles = 0
        self.stopped: str | None = None
        """Why the trace stopped early, if it did."""

    @property
    def replaying(self) -> bool:
        """Whether the trace goes on, and needs more cycles (replay has not stopped)."""
        return self.stopped is None

    reading = replaying

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        """Add the next cycle's outcome (ignored once the trace has stopped)."""
        if self.stopped is not None or outcome is None:
            return
        stop = self._stop(outcome)
        if stop is not None:
            self.stopped = f"cycle {outcome.cycle}: {stop.message}"
            return
        names = self._names
        self._changes.extend(
            TracedStateChange(outcome.cycle, outcome.time_ns, StateChange(names[i], before, after))
            for i, before, after in outcome.changes or ()
        )
        self._outputs.extend(self._tracker.observe(outcome.cycle, outcome.time_ns, outcome.outputs))
        if outcome.perception_differs:  # approved where it differs from the recorded bit for bit
            state = outcome.state
            fields = rebuilt_otherwise(state_fields(outcome.recorded_state), state_fields(state))
            if fields:
                digest = state_digest(self._encode(state))
                self._states.append(RebuiltState(outcome.cycle, outcome.time_ns, fields, digest))
        if outcome.draws_otherwise:
            self._draws.extend((outcome.cycle, d) for d in outcome.draws_otherwise)
        self._departures.add(
            outcome.record, outcome.cycle, outcome.time_ns, outcome.changes or (), outcome.outputs
        )
        self._cycles += 1

    def trace(self) -> ReplayedTrace:
        """The trace gathered so far."""
        return ReplayedTrace(
            tuple(self._changes),
            self._cycles,
            self.stopped,
            tuple(self._outputs),
            dataclasses.replace(
                self._departures.departures(),
                approved_states=ApprovedStates.from_rebuilt(self._states),
                draws=approved_draws(self._draws),
            ),
        )
