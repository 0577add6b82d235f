"""Whole-session traces of behavior state changes: the recorded one and a replayed one.

Replay stops at the first divergence; re-baselining an intended change and proposing
a rename need the whole trace instead, so these walk every cycle of a log.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from beatlog.engine.cycle import CycleExecutor, StateChangeRecord
from beatlog.engine.fit import check_fit
from beatlog.engine.verdict import StateChange
from beatlog.errors import CorruptLogError, SchemaMismatchError
from beatlog.log.format import DECODE_ERRORS, EMPTY_LIST, CycleRecord
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import System
from beatlog.model.random import Draw, RandomMismatch, ReplayRandom

__all__ = [
    "ReplayInputs",
    "ReplayedTrace",
    "TracedChange",
    "fields_read",
    "recorded_trace",
    "replayed_trace",
]


class TracedChange(NamedTuple):
    """A state change at a cycle of the session."""

    cycle: int
    time_ns: int
    change: StateChange


@dataclass(frozen=True)
class ReplayedTrace:
    """The state changes a system makes over a whole session log."""

    changes: tuple[TracedChange, ...]
    cycles: int
    """Cycles replayed."""
    stopped: str | None
    """Why replay stopped before the end of the log (the behaviors raised or drew
    random numbers the log does not have), or None when it replayed every cycle."""


def recorded_trace(log: str | Path) -> list[TracedChange]:
    """Every state change the log recorded, named by the log's behavior catalogue."""
    decode = msgspec.msgpack.Decoder(list[StateChangeRecord]).decode
    with SessionLogReader(log) as reader:
        names = reader.header.behaviors
        changes: list[TracedChange] = []
        time_ns = 0
        for cycle, record in enumerate(_records(reader)):
            time_ns += record.heartbeat_ns
            if record.state_changes != EMPTY_LIST:
                try:
                    recorded = decode(record.state_changes)
                except DECODE_ERRORS as exc:
                    raise CorruptLogError(
                        reader.path, f"damaged state changes in cycle {cycle}: {exc}"
                    ) from None
                for index, before, after in recorded:
                    name = names[index] if 0 <= index < len(names) else f"#{index}"
                    changes.append(TracedChange(cycle, time_ns, StateChange(name, before, after)))
    return changes


def replayed_trace(log: str | Path, system: System) -> ReplayedTrace:
    """Replay every cycle of ``log`` on ``system`` and collect its state changes.

    Replay uses the recording's heartbeats, robot states and random numbers; it stops
    early when the behaviors raise or draw random numbers the log does not have.
    """
    replayer = ReplayInputs(system)
    names = replayer.executor.behavior_ids
    random = replayer.random
    changes: list[TracedChange] = []
    stopped: str | None = None
    cycles = 0
    with SessionLogReader(log) as reader:
        for cycle, record, state in replayer.cycles(reader):
            try:
                stepped = replayer.executor.step(record.heartbeat_ns, state)
            except RandomMismatch as mismatch:
                stopped = f"cycle {cycle}: {mismatch.problem}"
                break
            except Exception as exc:  # behavior code failing ends the trace, it is reported
                stopped = f"cycle {cycle}: {type(exc).__name__}: {exc}"
                break
            if len(random.drawn) != len(random.recorded):
                stopped = (
                    f"cycle {cycle}: drew {len(random.drawn)} random numbers where "
                    f"{len(random.recorded)} were recorded"
                )
                break
            time_ns = replayer.executor.context.time_ns
            changes.extend(
                TracedChange(cycle, time_ns, StateChange(names[index], before, after))
                for index, before, after in stepped
            )
            cycles += 1
    return ReplayedTrace(tuple(changes), cycles, stopped)


class _ReadTracker:
    """Stands in for a robot state and notes which fields the behaviors read."""

    def __init__(self, state: Any) -> None:
        self._state = state
        self.read: dict[str, None] = {}

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._state, name)
        self.read[name] = None
        return value


def fields_read(log: str | Path, system: System, cycle: int) -> tuple[str, ...]:
    """The robot-state fields a fresh ``system`` reads in ``cycle`` of ``log``, in order.

    Replays the cycles before it as recorded; empty when replay cannot get there or
    the behaviors do not accept the stand-in state.
    """
    replayer = ReplayInputs(system)
    with SessionLogReader(log) as reader:
        for index, record, state in itertools.islice(replayer.cycles(reader), cycle + 1):
            tracker = _ReadTracker(state) if index == cycle else None
            try:
                replayer.executor.step(record.heartbeat_ns, tracker or state)
            except (Exception, RandomMismatch):  # the diverging cycle may raise: keep its reads
                if tracker is None:
                    return ()
            if tracker is not None:
                return tuple(tracker.read)
    return ()


class ReplayInputs:
    """A system set up for replay, and each recorded cycle's RS_t decoded with RN_t loaded."""

    def __init__(self, system: System) -> None:
        self.random = ReplayRandom()
        self.executor = CycleExecutor(system, self.random)
        self._state_type = system.robot_state.__name__
        self._state = msgspec.msgpack.Decoder(system.robot_state).decode
        self._draws = msgspec.msgpack.Decoder(list[Draw]).decode

    def load(self, path: Path, cycle: int, record: CycleRecord) -> Any:
        """RS_t of ``record``, with its random numbers loaded for the behaviors to draw."""
        try:
            state = self._state(record.robot_state)
        except DECODE_ERRORS as exc:
            raise SchemaMismatchError(
                path, f"robot state of cycle {cycle} does not fit {self._state_type}: {exc}"
            ) from None
        try:
            self.random.load(
                () if record.random_numbers == EMPTY_LIST else self._draws(record.random_numbers)
            )
        except DECODE_ERRORS as exc:
            raise CorruptLogError(path, f"damaged random numbers in cycle {cycle}: {exc}") from None
        return state

    def cycles(self, reader: SessionLogReader) -> Iterator[tuple[int, CycleRecord, Any]]:
        """Every cycle of the log with its RS_t, ready to step; the log must fit the system."""
        check_fit(reader.header, self.executor.system, reader.path)
        for cycle, record in enumerate(_records(reader)):
            yield cycle, record, self.load(reader.path, cycle, record)


def _records(reader: SessionLogReader) -> Iterator[CycleRecord]:
    return itertools.chain.from_iterable(reader.batches())
