"""Where the behaviors depart from the recording: what a baseline holds since format 5.

The recording always lies beside its baseline, so a baseline holds only where the
approved state changes and outputs differ from the recorded ones: a cycle's own state
changes (none, where it is *quiet*), and an output field's approved value from a cycle
on, until it is :data:`~beatlog.replay.baseline.AS_RECORDED` again.
:class:`DepartureCollector` finds them as a trace replays; :class:`BaselineRecords`
puts them, encoded as a log would, into the recorded cycles replay reads, so that the
judge compares bytes as ever (the approved outputs by :class:`ApprovedOutputs`).
"""

from __future__ import annotations

import itertools
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from operator import attrgetter, itemgetter
from pathlib import Path
from typing import Any

import msgspec

from beatlog.errors import CorruptLogError
from beatlog.log.format import (
    DECODE_ERRORS,
    EMPTY_LIST,
    EMPTY_MAP,
    CycleRecord,
    LoggedStateChange,
    payload_encoder,
)
from beatlog.log.payload import decode_outputs
from beatlog.model.cycle import actor_name
from beatlog.replay.approved_states import ApprovedStateChecker
from beatlog.replay.baseline import (
    ABSENT,
    AS_RECORDED,
    Baseline,
    BaselinePart,
    BaselineStream,
    TracedOutput,
    TracedStateChange,
    changes_by_cycle,
)
from beatlog.replay.verdict import StateChange

__all__ = [
    "ApprovedOutputs",
    "BaselineRecords",
    "DepartureCollector",
    "OutputDepartures",
    "apply_outputs",
    "hold",
]


class OutputDepartures:
    """Turns each cycle's outputs, recorded and replayed, into the output lines of
    departures: a line wherever a field's held value no longer gives the one replayed
    (bit for bit, as :class:`~beatlog.replay.baseline.OutputTracker` compares)."""

    def __init__(self) -> None:
        self._sorted = msgspec.msgpack.Encoder(enc_hook=payload_encoder().enc_hook, order="sorted")
        self._held: dict[str, bytes | None] = {}
        """The fields that depart, each with its value held (None: held absent)."""

    def observe(
        self,
        cycle: int,
        time_ns: int,
        recorded: Mapping[str, Any],
        outputs: Mapping[str, Any],
    ) -> list[TracedOutput]:
        """The lines a cycle needs: ``recorded`` and ``outputs`` as they read back from
        a log (numpy arrays as lists)."""
        encode = self._sorted.encode
        held = self._held
        lines: list[TracedOutput] = []
        for name in sorted(recorded.keys() | outputs.keys() | held.keys()):
            now = encode(outputs[name]) if name in outputs else None
            was = encode(recorded[name]) if name in recorded else None
            if held.get(name, was) == now:
                continue
            if was == now:
                del held[name]
                lines.append(TracedOutput(cycle, time_ns, name, AS_RECORDED))
            else:
                held[name] = now
                lines.append(TracedOutput(cycle, time_ns, name, outputs.get(name, ABSENT)))
        return lines

    @property
    def departing(self) -> bool:
        """Whether a field holds a value other than the recorded one now."""
        return bool(self._held)


def hold(held: dict[str, Any], lines: Iterable[TracedOutput]) -> None:
    """Take a cycle's output lines of departures into ``held``, the values that stand in
    for the recorded ones from then on."""
    for line in lines:
        if line.value is AS_RECORDED:
            held.pop(line.field, None)
        else:
            held[line.field] = line.value


def apply_outputs(recorded: dict[str, Any], held: Mapping[str, Any]) -> dict[str, Any]:
    """A cycle's recorded outputs with the held values of departing fields in place
    (:data:`~beatlog.replay.baseline.ABSENT` ones removed); ``recorded`` is changed."""
    for name, value in held.items():
        if value is ABSENT:
            recorded.pop(name, None)
        else:
            recorded[name] = value
    return recorded


class DepartureCollector:
    """Gathers a session's departures from the recording, cycle by cycle, as a trace
    replays it: ``names`` are the system's behaviors, ``recorded_names`` the log's in
    the names they have now."""

    def __init__(self, names: list[str], recorded_names: list[str]) -> None:
        self._names = names
        self._recorded_names = recorded_names
        self._encode = payload_encoder().encode
        self._changes: list[TracedStateChange] = []
        self._quiet: list[tuple[int, int]] = []
        self._outputs: list[TracedOutput] = []
        self._output_departures = OutputDepartures()
        self._first: tuple[int, int] | None = None

    def add(
        self,
        record: CycleRecord,
        cycle: int,
        time_ns: int,
        changes: Iterable[tuple[int, Any, Any]],
        outputs: Mapping[str, Any],
    ) -> None:
        """Add a cycle: its record and the state changes and outputs replayed in it."""
        changes = list(changes)
        departed = False
        if self._changes_depart(record.state_changes, changes):
            departed = True
            names = self._names
            self._changes.extend(
                TracedStateChange(cycle, time_ns, StateChange(names[i], before, after))
                for i, before, after in changes
            )
            if not changes:
                self._quiet.append((cycle, time_ns))
        encoded = EMPTY_MAP if not outputs else msgspec.Raw(self._encode(outputs))
        if record.outputs != encoded or self._output_departures.departing:
            lines = self._output_departures.observe(
                cycle,
                time_ns,
                msgspec.msgpack.decode(record.outputs),
                msgspec.msgpack.decode(encoded),
            )
            departed = departed or bool(lines)
            self._outputs.extend(lines)
        if departed and self._first is None:
            self._first = (cycle, time_ns)

    def _changes_depart(self, recorded: msgspec.Raw, changes: list[tuple[int, Any, Any]]) -> bool:
        """Whether the state changes replayed are not the recorded ones (as a set)."""
        if not changes and recorded == EMPTY_LIST:
            return False
        encode, names, then = self._encode, self._names, self._recorded_names
        was = {
            (actor_name(then, i), encode(b), encode(a))
            for i, b, a in msgspec.msgpack.decode(recorded)
        }
        return was != {(names[i], encode(b), encode(a)) for i, b, a in changes}

    def departures(self) -> Baseline:
        """The departures gathered so far, as a baseline holds them (no robot states
        pinned, no draws approved: those are gathered apart)."""
        return Baseline(
            tuple(self._changes),
            tuple(self._outputs),
            open_loop=self._first,
            quiet=tuple(self._quiet),
        )


class ApprovedOutputs:
    """The approved values departing output fields hold, from a baseline's output lines,
    put into the recorded cycles' outputs (``path`` names the log in errors)."""

    def __init__(self, path: Path) -> None:
        self._path = path
        self._encode = payload_encoder().encode
        self._held: dict[str, Any] = {}

    def hold(self, lines: Iterable[TracedOutput]) -> bool:
        """Take a cycle's output lines; whether any field holds a value now."""
        hold(self._held, lines)
        return bool(self._held)

    def put(self, records: Sequence[CycleRecord], cycle: int) -> None:
        """Put the expected outputs into ``records``, cycles ``cycle`` on, in place of
        the recorded ones.

        :raises beatlog.errors.CorruptLogError: a cycle's outputs are damaged.
        """
        for at, record in enumerate(records, cycle):
            try:
                decoded = decode_outputs(record.outputs)
            except DECODE_ERRORS as exc:
                raise CorruptLogError(self._path, f"damaged outputs in cycle {at}: {exc}") from None
            apply_outputs(decoded, self._held)
            record.outputs = msgspec.Raw(self._encode(decoded)) if decoded else EMPTY_MAP


_CYCLE = attrgetter("cycle")
_FIRST = itemgetter(0)
_ALL = 1 << 62
"""Past any cycle: every part is read."""


class BaselineRecords:
    """An approved baseline's state changes and outputs, encoded to stand in for the
    recorded ones, cycle by cycle, and its approved robot states handed to ``approved``.

    ``recorded_names`` is the log's behavior catalogue and ``rename`` maps a recorded
    name to its name now. :attr:`names` is the catalogue the expected state changes are
    encoded by: the log's (the other cycles keep the recorded bytes); behaviors the
    baseline names but that catalogue lacks get indices past it.
    """

    def __init__(
        self,
        baseline: BaselineStream,
        recorded_names: Sequence[str],
        rename: Callable[[str], str],
        approved: ApprovedStateChecker | None,
    ) -> None:
        self._encoder = payload_encoder()
        names = list(recorded_names)
        index: dict[str, int] = {}
        for position, name in enumerate(names):
            index.setdefault(rename(name), position)
        for behavior in baseline.behaviors:
            if behavior not in index:
                index[behavior] = len(names)
                names.append(behavior)
        self.names = names
        self._index = index
        self._baseline = baseline
        self._approved_states = approved
        self._changes: deque[tuple[int, list[StateChange]]] = deque()
        """The state changes of the cycles read and not yet handed on, by cycle."""
        self._lines: deque[tuple[int, list[TracedOutput]]] = deque()
        """Likewise the output lines."""
        self._read = -1
        """The last cycle of the parts read: every line of an earlier one is read."""

    def _encode_changes(self, changes: list[StateChange]) -> msgspec.Raw:
        index = self._index
        records: list[LoggedStateChange] = [
            (index[behavior], before, after) for behavior, before, after in changes
        ]
        return msgspec.Raw(self._encoder.encode(records)) if records else EMPTY_LIST

    def _read_to(self, parts: Iterator[BaselinePart], end: int) -> None:
        """Read parts until every line of a cycle before ``end`` is read."""
        while self._read < end:
            part = next(parts, None)
            if part is None:
                self._read = _ALL
                return
            grouped = changes_by_cycle(part.changes, part.quiet)
            _queue(self._changes, sorted(grouped.items(), key=_FIRST))
            _queue(
                self._lines,
                ((cycle, list(lines)) for cycle, lines in itertools.groupby(part.outputs, _CYCLE)),
            )
            if self._approved_states is not None:
                self._approved_states.add(part.runs, part.blocks)
            self._read = max(self._read, part.last)

    def batches(
        self, batches: Iterator[Sequence[CycleRecord]], path: Any, first: int = 0
    ) -> Iterator[Sequence[CycleRecord]]:
        """The log's batches, cycle ``first`` on (a fresh start's), with the expected
        state changes and outputs in place of the recorded ones (``path`` names the log
        in errors), the baseline read alongside: what it expects of the cycles before
        ``first`` is read past, the output values it holds from them kept."""
        parts = self._baseline.parts()
        self._read = -1
        outputs = ApprovedOutputs(path)
        holding = False
        cycle = first
        if first:
            self._read_to(parts, first)
            _take(self._changes, first)
            for held in _take(self._lines, first).values():
                holding = outputs.hold(held)
        for batch in batches:
            start, end = cycle, cycle + len(batch)
            self._read_to(parts, end)
            if self._approved_states is not None:
                self._approved_states.forget(start)
            changes = {at: self._encode_changes(c) for at, c in _take(self._changes, end).items()}
            lines = _take(self._lines, end)
            for event in sorted(changes.keys() | lines.keys()):
                if holding:
                    outputs.put(batch[start - cycle : event - cycle], start)
                if event in changes:
                    batch[event - cycle].state_changes = changes[event]
                if event in lines:
                    holding = outputs.hold(lines[event])
                start = event
            if holding:
                outputs.put(batch[start - cycle :] if start > cycle else batch, start)
            cycle = end
            yield batch


def _queue(queue: deque[tuple[int, list[Any]]], by_cycle: Iterable[tuple[int, list[Any]]]) -> None:
    """Queue the lines of each cycle, those of the cycle queued last joining its own
    (a part may end within a cycle's lines)."""
    for cycle, lines in by_cycle:
        if queue and queue[-1][0] == cycle:
            queue[-1][1].extend(lines)
        else:
            queue.append((cycle, lines))


def _take(queue: deque[tuple[int, list[Any]]], end: int) -> dict[int, list[Any]]:
    """The lines queued of the cycles before ``end``, by cycle, taken off ``queue``."""
    taken = {}
    while queue and queue[0][0] < end:
        at, lines = queue.popleft()
        taken[at] = lines
    return taken
