"""What replay judges against: a trace of state changes, outputs and robot states, and
an approved baseline (:class:`Expectation`) made of one.

Outputs are traced compactly: a field appears only in the cycles where its value
changes (:class:`OutputTracker`). A baseline made since format 5 holds only where the
behaviors depart from the recording (:mod:`beatlog.replaying.departures`), the rest being
as recorded.
"""

from __future__ import annotations

import enum
import itertools
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from operator import attrgetter
from typing import Any, NamedTuple

import msgspec

from beatlog.log.format import payload_encoder
from beatlog.replaying.draws import DrawRule
from beatlog.replaying.pins import StatePins
from beatlog.replaying.verdict import StateChange

__all__ = [
    "ABSENT",
    "AS_RECORDED",
    "EveryCycle",
    "Expectation",
    "OutputTracker",
    "TracedChange",
    "TracedOutput",
    "TracedState",
]

_CYCLE = attrgetter("cycle")


class TracedChange(NamedTuple):
    """A state change at a cycle of the session."""

    cycle: int
    time_ns: int
    change: StateChange


class _Marker(enum.Enum):
    ABSENT = "absent"
    AS_RECORDED = "as recorded"

    def __repr__(self) -> str:
        return self.name


ABSENT = _Marker.ABSENT
"""The value of a :class:`TracedOutput` whose field is no longer output from that cycle on."""
AS_RECORDED = _Marker.AS_RECORDED
"""The value of a :class:`TracedOutput` of departures (:attr:`Expectation.departures`)
whose field is output as recorded again from that cycle on."""


class TracedOutput(NamedTuple):
    """An output field that took a new value (or went :data:`ABSENT`) at a cycle."""

    cycle: int
    time_ns: int
    field: str
    value: Any


class TracedState(NamedTuple):
    """A robot-state field that the perception step rebuilt differently from the
    recorded RS_t at a cycle, with the value it rebuilt: how a format 3 baseline pins
    robot states (newer ones pin them by digest, :class:`~beatlog.replaying.pins.StatePins`)."""

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


class EveryCycle(dict[int, list[StateChange]]):
    """State changes by cycle that stand in for the recorded ones in every cycle, a
    whole trace's: a cycle it does not list has none."""

    def __contains__(self, cycle: object) -> bool:
        return True

    def __missing__(self, cycle: int) -> list[StateChange]:
        return []


@dataclass(frozen=True)
class Expectation:
    """What replay judges against instead of the recording: an approved baseline.

    ``outputs`` pins the outputs as compact changes (see :class:`OutputTracker`); None
    (a baseline from before outputs were pinned) leaves them judged against the recording.
    ``robot_states`` pins, for sensor-level replay, the robot states an intended
    perception change rebuilds (format 3: the fields that differ from the recorded RS_t,
    value by value); ``state_pins`` pins them by digest, in the cycles where they differ
    from the recorded RS_t (none: perception rebuilds the recording). ``draws`` are the
    draws replay may make otherwise than recorded (:mod:`beatlog.replaying.draws`); a
    baseline is judged in living replay, so any other difference diverges.
    ``open_loop`` is the first cycle whose state changes or outputs left the
    recording's, if any: from there the recorded world no longer answers to what the
    behaviors do.

    With ``departures`` set (a baseline since format 5), ``changes`` and ``outputs`` say
    only where the behaviors depart from the recording: in a cycle that ``changes`` or
    ``quiet`` lists, its state changes stand in for the recorded ones (none, in a quiet
    cycle), and any other cycle's are as recorded; an output field holds the value an
    output line gives it (:data:`ABSENT` included) from that cycle on, whatever was
    recorded, until a line gives it :data:`AS_RECORDED` again.
    """

    changes: tuple[TracedChange, ...]
    outputs: tuple[TracedOutput, ...] | None = None
    robot_states: tuple[TracedState, ...] = ()
    state_pins: StatePins = field(default_factory=StatePins)
    draws: tuple[DrawRule, ...] = ()
    open_loop: tuple[int, int] | None = None
    """The cycle and robot time (ns) where the behaviors left the recording."""
    departures: bool = False
    """Whether ``changes``, ``quiet`` and ``outputs`` say only where the behaviors depart
    from the recording (else they are the whole trace)."""
    quiet: tuple[tuple[int, int], ...] = ()
    """With ``departures``: the cycles (and robot times) whose recorded state changes
    are gone, none standing in for them."""

    @property
    def as_recorded(self) -> bool:
        """Whether the behaviors' state changes and outputs are the recording's (the
        change approved moved only robot states or draws)."""
        return self.departures and not (self.changes or self.quiet or self.outputs)

    def changes_override(self) -> dict[int, list[StateChange]] | None:
        """The state changes that stand in for the recorded ones, in the cycles the
        mapping holds (an :class:`EveryCycle` for a whole trace); None where the
        recording's hold in every cycle."""
        if self.as_recorded:
            return None
        grouped = self.changes_by_cycle()
        if not self.departures:
            return EveryCycle(grouped)
        for cycle, _ in self.quiet:
            grouped[cycle] = []
        return grouped

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
        for cycle, changes in itertools.groupby(self.outputs or (), key=_CYCLE):
            for change in changes:
                if change.value is ABSENT:
                    current.pop(change.field, None)
                else:
                    current[change.field] = change.value
            yield cycle, dict(current)
