"""What replay judges against: a trace of state changes, outputs and robot states, and
an approved baseline (:class:`Expectation`) made of one.

Outputs are traced compactly: a field appears only in the cycles where its value
changes (:class:`OutputTracker`).
"""

from __future__ import annotations

import enum
import itertools
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import msgspec

from beatlog.log.format import payload_encoder
from beatlog.replay.draws import DrawRule
from beatlog.replay.pins import StatePins
from beatlog.replay.verdict import StateChange

__all__ = [
    "ABSENT",
    "Expectation",
    "OutputTracker",
    "TracedChange",
    "TracedOutput",
    "TracedState",
]


class TracedChange(NamedTuple):
    """A state change at a cycle of the session."""

    cycle: int
    time_ns: int
    change: StateChange


class _Absent(enum.Enum):
    ABSENT = "absent"

    def __repr__(self) -> str:
        return "ABSENT"


ABSENT = _Absent.ABSENT
"""The value of a :class:`TracedOutput` whose field is no longer output from that cycle on."""


class TracedOutput(NamedTuple):
    """An output field that took a new value (or went :data:`ABSENT`) at a cycle."""

    cycle: int
    time_ns: int
    field: str
    value: Any


class TracedState(NamedTuple):
    """A robot-state field that the perception step rebuilt differently from the
    recorded RS_t at a cycle, with the value it rebuilt: how a format 3 baseline pins
    robot states (newer ones pin them by digest, :class:`~beatlog.replay.pins.StatePins`)."""

    cycle: int
    time_ns: int
    field: str
    value: Any


class OutputTracker:
    """Turns each cycle's outputs into the fields whose value changed, bit for bit.

    Values are kept as they read back from a log (numpy arrays become lists), so a
    trace of replayed outputs equals the trace of the same outputs recorded.
    """

    def __init__(self) -> None:
        self._encode = payload_encoder().encode
        self._sorted = msgspec.msgpack.Encoder(enc_hook=payload_encoder().enc_hook, order="sorted")
        self._current: dict[str, bytes] = {}

    def observe(self, cycle: int, time_ns: int, outputs: Mapping[str, Any]) -> list[TracedOutput]:
        """The changes in ``outputs`` since the previous cycle observed."""
        current = self._current
        changed: list[TracedOutput] = []
        if outputs:
            values = msgspec.msgpack.decode(self._encode(outputs))
            for name in sorted(values):
                encoded = self._sorted.encode(values[name])
                if current.get(name) != encoded:
                    current[name] = encoded
                    changed.append(TracedOutput(cycle, time_ns, name, values[name]))
        for name in sorted(current.keys() - outputs.keys()):
            del current[name]
            changed.append(TracedOutput(cycle, time_ns, name, ABSENT))
        return changed


@dataclass(frozen=True)
class Expectation:
    """What replay judges against instead of the recording: an approved baseline.

    ``outputs`` pins the outputs as compact changes (see :class:`OutputTracker`); None
    (a baseline from before outputs were pinned) leaves them judged against the recording.
    ``robot_states`` pins, for sensor-level replay, the robot states an intended
    perception change rebuilds (format 3: the fields that differ from the recorded RS_t,
    value by value); ``state_pins`` pins them by digest, in the cycles where they differ
    from the recorded RS_t (none: perception rebuilds the recording). ``draws`` are the
    draws replay may make otherwise than recorded (:mod:`beatlog.replay.draws`); a
    baseline is judged in living replay, so any other difference diverges.
    ``open_loop`` is the first cycle whose state changes or outputs left the
    recording's, if any: from there the recorded world no longer answers to what the
    behaviors do.
    """

    changes: tuple[TracedChange, ...]
    outputs: tuple[TracedOutput, ...] | None = None
    robot_states: tuple[TracedState, ...] = ()
    state_pins: StatePins = field(default_factory=StatePins)
    draws: tuple[DrawRule, ...] = ()
    open_loop: tuple[int, int] | None = None
    """The cycle and robot time (ns) where the behaviors left the recording."""
    as_recorded: bool = False
    """Whether the behaviors' state changes and outputs are the recording's (the change
    approved moved only robot states or draws): then ``changes`` and ``outputs`` pin
    nothing, and they are judged against the recording."""

    def changes_override(self) -> dict[int, list[StateChange]] | None:
        """The state changes that stand in for the recorded ones, by cycle; None where
        the recording's hold."""
        return None if self.as_recorded else self.changes_by_cycle()

    def changes_by_cycle(self) -> dict[int, list[StateChange]]:
        """The state changes grouped by cycle."""
        grouped: dict[int, list[StateChange]] = {}
        for traced in self.changes:
            grouped.setdefault(traced.cycle, []).append(traced.change)
        return grouped

    def states_by_cycle(self) -> dict[int, dict[str, Any]]:
        """The robot-state fields a format 3 baseline pins, grouped by cycle."""
        grouped: dict[int, dict[str, Any]] = {}
        for traced in self.robot_states:
            grouped.setdefault(traced.cycle, {})[traced.field] = traced.value
        return grouped

    def outputs_by_cycle(self) -> Iterator[tuple[int, dict[str, Any]]]:
        """Each cycle where an output changes, with every output field from then on."""
        current: dict[str, Any] = {}
        for cycle, changes in itertools.groupby(self.outputs or (), key=lambda o: o.cycle):
            for change in changes:
                if change.value is ABSENT:
                    current.pop(change.field, None)
                else:
                    current[change.field] = change.value
            yield cycle, dict(current)
