"""The baseline as replay judges against it: where the behaviors depart from the
recording, whole in memory (:class:`Baseline`) or read a part at a time in cycle order
(:class:`BaselineStream`) so that a big one is judged in bounded memory; and the lines it
is made of, behavior state changes and outputs traced at a cycle, an output only where
its value changes (:class:`OutputTracker`). :mod:`beatlog.baseline` reads and writes its
file.
"""

from __future__ import annotations

import enum
import itertools
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from operator import attrgetter
from typing import Any, NamedTuple

import msgspec

from beatlog.log.format import payload_encoder
from beatlog.replay.approved_state_lines import ApprovedRun, DigestBlock
from beatlog.replay.approved_states import ApprovedStates
from beatlog.replay.draws import ApprovedDraws
from beatlog.replay.verdict import StateChange

__all__ = [
    "ABSENT",
    "AS_RECORDED",
    "Baseline",
    "BaselinePart",
    "BaselineStream",
    "OutputTracker",
    "TracedOutput",
    "TracedStateChange",
    "changes_by_cycle",
]

_CYCLE = attrgetter("cycle")


class TracedStateChange(NamedTuple):
    """A :class:`StateChange` traced at a cycle of the session, and its robot time."""

    cycle: int
    time_ns: int
    change: StateChange


def changes_by_cycle(
    changes: Iterable[TracedStateChange], quiet: Iterable[tuple[int, int]]
) -> dict[int, list[StateChange]]:
    """State changes grouped by cycle, a ``quiet`` cycle (and robot time) with none."""
    grouped: dict[int, list[StateChange]] = {}
    for traced in changes:
        grouped.setdefault(traced.cycle, []).append(traced.change)
    for cycle, _ in quiet:
        grouped[cycle] = []
    return grouped


class _Marker(enum.Enum):
    ABSENT = "absent"
    AS_RECORDED = "as recorded"

    def __repr__(self) -> str:
        return self.name


ABSENT = _Marker.ABSENT
"""The value of a :class:`TracedOutput` whose field is no longer output from that cycle on."""
AS_RECORDED = _Marker.AS_RECORDED
"""The value of a :class:`TracedOutput` of departures whose field is output as recorded
again from that cycle on."""


class TracedOutput(NamedTuple):
    """An output field that took a new value (or went :data:`ABSENT`) at a cycle."""

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
class Baseline:
    """A baseline, whole in memory: what replay judges against instead of the recording
    once approved, where the behaviors depart from it.

    In a cycle that ``changes`` or ``quiet`` lists, its state changes stand in for the
    recorded ones (none, in a quiet cycle), and any other cycle's are as recorded; an
    output field holds the value an output line gives it (:data:`ABSENT` included) from
    that cycle on, whatever was recorded, until a line gives it :data:`AS_RECORDED`
    again. ``approved_states`` are, for sensor-level replay, the robot states an intended
    perception change rebuilds, by digest, in the cycles where they differ from the
    recorded RS_t (none: perception rebuilds the recording). ``draws`` are the draws
    replay may make otherwise than recorded (:mod:`beatlog.replay.draws`); a baseline
    is judged in replay matching draws, so any other difference diverges. ``open_loop`` is the
    first cycle whose state changes or outputs left the recording's, if any: from there
    the recorded world no longer answers to what the behaviors do.
    """

    changes: tuple[TracedStateChange, ...]
    outputs: tuple[TracedOutput, ...] = ()
    approved_states: ApprovedStates = field(default_factory=ApprovedStates)
    draws: tuple[ApprovedDraws, ...] = ()
    open_loop: tuple[int, int] | None = None
    """The cycle and robot time (ns) where the behaviors left the recording."""
    quiet: tuple[tuple[int, int], ...] = ()
    """The cycles (and robot times) whose recorded state changes are gone, none
    standing in for them."""

    @property
    def as_recorded(self) -> bool:
        """Whether the behaviors' state changes and outputs are the recording's (the
        change approved moved only robot states or draws)."""
        return not (self.changes or self.quiet or self.outputs)

    def changes_override(self) -> dict[int, list[StateChange]] | None:
        """The state changes that stand in for the recorded ones, in the cycles the
        mapping holds; None where the recording's hold in every cycle."""
        return None if self.as_recorded else changes_by_cycle(self.changes, self.quiet)

    def outputs_by_cycle(self) -> Iterator[tuple[int, dict[str, Any]]]:
        """Each cycle where an output changes, with every output field from then on."""
        current: dict[str, Any] = {}
        for cycle, changes in itertools.groupby(self.outputs, key=_CYCLE):
            for change in changes:
                if change.value is ABSENT:
                    current.pop(change.field, None)
                else:
                    current[change.field] = change.value
            yield cycle, dict(current)

    def stream(self) -> BaselineStream:
        """This baseline as replay reads it: in one part."""
        approved = self.approved_states
        part = BaselinePart(self.changes, self.quiet, self.outputs, approved.runs, approved.blocks)
        return BaselineStream(
            self.draws,
            self.open_loop,
            departs=not self.as_recorded,
            pinned=bool(approved.blocks),
            behaviors=tuple(dict.fromkeys(c.change.behavior for c in self.changes)),
            parts=lambda: iter((part,)),
        )


class BaselinePart(NamedTuple):
    """Some of a baseline's lines of cycles, each kind in cycle order: a part of a
    :class:`BaselineStream`, whose next part has none of an earlier cycle than these."""

    changes: Sequence[TracedStateChange]
    quiet: Sequence[tuple[int, int]]
    outputs: Sequence[TracedOutput]
    runs: Sequence[ApprovedRun]
    blocks: Sequence[DigestBlock]

    @property
    def last(self) -> int:
        """The last cycle it has a line of (-1: none): each line's first field is its
        cycle."""
        kinds: tuple[Sequence[tuple[Any, ...]], ...] = tuple(self)
        return max((kind[-1][0] for kind in kinds if kind), default=-1)


@dataclass(frozen=True)
class BaselineStream:
    """A baseline as replay reads it, alongside the log: what applies to the whole
    session, and its lines of cycles read afresh a part at a time, in cycle order
    (:attr:`parts`), so that replay holds no more of a big baseline than a part and the
    cycles of the log's batch it judges.

    ``departs`` says whether any state changes or outputs depart from the recording,
    ``pinned`` whether any robot states are pinned, ``behaviors`` the names the state
    changes give, in the order they first appear.
    """

    draws: tuple[ApprovedDraws, ...]
    open_loop: tuple[int, int] | None
    departs: bool
    pinned: bool
    behaviors: tuple[str, ...]
    parts: Callable[[], Iterator[BaselinePart]]
    """Each call reads the lines afresh, from the first."""
