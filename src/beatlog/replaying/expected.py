"""The recorded cycles as an approved baseline expects them, for the judge to compare.

Replay judges a cycle by comparing the bytes the behaviors produce with the record's
(:mod:`beatlog.replaying.judge`). Against an approved baseline, :class:`ExpectedRecords`
puts the expected state changes and outputs in each record as replay reads it,
encoded as a log would: a whole trace (baseline formats 1 to 4) stands in for every
cycle's, departures (format 5, :mod:`beatlog.replaying.departures`) only where the
behaviors depart from the recording, every other cycle keeping its recorded bytes.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator, Sequence
from operator import attrgetter
from typing import Any

import msgspec

from beatlog.log.format import (
    EMPTY_LIST,
    EMPTY_MAP,
    CycleRecord,
    StateChangeRecord,
    payload_encoder,
)
from beatlog.replaying.expectation import Expectation, TracedOutput
from beatlog.replaying.held_outputs import HeldOutputs
from beatlog.replaying.verdict import StateChange

__all__ = ["ExpectedRecords"]

_CYCLE = attrgetter("cycle")


class ExpectedRecords:
    """An approved baseline's state changes and outputs, encoded to stand in for the
    recorded ones, cycle by cycle.

    ``system_names`` is the system's behavior catalogue, ``recorded_names`` the log's
    and ``rename`` maps a recorded name to its name now. :attr:`names` is the catalogue
    the expected state changes are encoded by: the system's for a whole trace, the
    log's for departures (whose other cycles keep the recorded bytes); behaviors the
    baseline names but that catalogue lacks get indices past it.
    """

    def __init__(
        self,
        expectation: Expectation,
        system_names: Sequence[str],
        recorded_names: Sequence[str],
        rename: Callable[[str], str],
    ) -> None:
        self._encoder = payload_encoder()
        self._departures = expectation.departures
        names = list(recorded_names if expectation.departures else system_names)
        index: dict[str, int] = {}
        for position, name in enumerate(names):
            index.setdefault(rename(name) if expectation.departures else name, position)
        self._changes: dict[int, msgspec.Raw] = {}
        for cycle, changes in (expectation.changes_override() or {}).items():
            self._changes[cycle] = self._encode_changes(changes, names, index)
        self.names = names
        self._outputs = expectation.outputs
        self.sorted_outputs = not expectation.departures and expectation.outputs is not None
        """Whether expected outputs are encoded with sorted keys (a whole trace's), not
        in the order the behaviors report them (the recording's)."""

    def _encode_changes(
        self, changes: list[StateChange], names: list[str], index: dict[str, int]
    ) -> msgspec.Raw:
        records: list[StateChangeRecord] = []
        for behavior, before, after in changes:
            if behavior not in index:
                index[behavior] = len(names)
                names.append(behavior)
            records.append((index[behavior], before, after))
        return msgspec.Raw(self._encoder.encode(records)) if records else EMPTY_LIST

    @property
    def pins_outputs(self) -> bool:
        """Whether the baseline pins outputs (a format 1 file does not)."""
        return self._outputs is not None

    def batches(
        self, batches: Iterator[Sequence[CycleRecord]], path: Any
    ) -> Iterator[Sequence[CycleRecord]]:
        """The log's batches with the expected state changes and outputs in place of the
        recorded ones (``path`` names the log in errors)."""
        if self._departures:
            yield from self._departed(batches, path)
        else:
            yield from self._whole(batches)

    def _whole(self, batches: Iterator[Sequence[CycleRecord]]) -> Iterator[Sequence[CycleRecord]]:
        changes = self._changes
        pinned = None if self._outputs is None else _whole_outputs(self._outputs)
        outputs = EMPTY_MAP
        cycle = 0
        for batch in batches:
            for record in batch:
                record.state_changes = changes.get(cycle, EMPTY_LIST)
                if pinned is not None:
                    outputs = pinned.get(cycle, outputs)
                    record.outputs = outputs
                cycle += 1
            yield batch

    def _departed(
        self, batches: Iterator[Sequence[CycleRecord]], path: Any
    ) -> Iterator[Sequence[CycleRecord]]:
        changes = self._changes
        lines = {
            cycle: list(outputs)
            for cycle, outputs in itertools.groupby(self._outputs or (), key=_CYCLE)
        }
        events = iter(sorted(changes.keys() | lines.keys()))
        """The cycles with departing state changes or output lines."""
        event = next(events, None)
        held = HeldOutputs(path)
        holding = False
        cycle = 0
        for batch in batches:
            start, end = cycle, cycle + len(batch)
            while event is not None and event < end:
                if holding:
                    held.put(batch[start - cycle : event - cycle], start)
                if event in changes:
                    batch[event - cycle].state_changes = changes[event]
                if event in lines:
                    holding = held.hold(lines[event])
                start, event = event, next(events, None)
            if holding:
                held.put(batch[start - cycle :] if start > cycle else batch, start)
            cycle = end
            yield batch


def _whole_outputs(outputs: Sequence[TracedOutput]) -> dict[int, msgspec.Raw]:
    """A whole trace's outputs in every cycle where they change, encoded with sorted keys."""
    encode = msgspec.msgpack.Encoder(order="sorted").encode
    expectation = Expectation((), tuple(outputs))
    return {cycle: msgspec.Raw(encode(values)) for cycle, values in expectation.outputs_by_cycle()}
