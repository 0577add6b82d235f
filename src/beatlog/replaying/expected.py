"""The recorded cycles as an approved baseline expects them, for the judge to compare.

Replay judges a cycle by comparing the bytes the behaviors produce with the record's
(:mod:`beatlog.replaying.judge`). Against an approved baseline, :class:`ExpectedRecords`
puts the expected state changes and outputs in each record as replay reads it,
encoded as a log would: the baseline's departures
(:mod:`beatlog.replaying.departures`) where the behaviors depart from the recording,
every other cycle keeping its recorded bytes.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator, Sequence
from operator import attrgetter
from typing import Any

import msgspec

from beatlog.log.format import EMPTY_LIST, CycleRecord, StateChangeRecord, payload_encoder
from beatlog.replaying.expectation import Expectation
from beatlog.replaying.held_outputs import HeldOutputs
from beatlog.replaying.verdict import StateChange

__all__ = ["ExpectedRecords"]

_CYCLE = attrgetter("cycle")


class ExpectedRecords:
    """An approved baseline's state changes and outputs, encoded to stand in for the
    recorded ones, cycle by cycle.

    ``recorded_names`` is the log's behavior catalogue and ``rename`` maps a recorded
    name to its name now. :attr:`names` is the catalogue the expected state changes are
    encoded by: the log's (the other cycles keep the recorded bytes); behaviors the
    baseline names but that catalogue lacks get indices past it.
    """

    def __init__(
        self,
        expectation: Expectation,
        recorded_names: Sequence[str],
        rename: Callable[[str], str],
    ) -> None:
        self._encoder = payload_encoder()
        names = list(recorded_names)
        index: dict[str, int] = {}
        for position, name in enumerate(names):
            index.setdefault(rename(name), position)
        self._changes: dict[int, msgspec.Raw] = {}
        for cycle, changes in (expectation.changes_override() or {}).items():
            self._changes[cycle] = self._encode_changes(changes, names, index)
        self.names = names
        self._outputs = expectation.outputs

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

    def batches(
        self, batches: Iterator[Sequence[CycleRecord]], path: Any
    ) -> Iterator[Sequence[CycleRecord]]:
        """The log's batches with the expected state changes and outputs in place of the
        recorded ones (``path`` names the log in errors)."""
        changes = self._changes
        lines = {
            cycle: list(outputs) for cycle, outputs in itertools.groupby(self._outputs, key=_CYCLE)
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
