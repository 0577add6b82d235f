"""The recorded cycles as an approved baseline expects them: :class:`BaselineRecords`
puts its state changes and outputs, encoded as a log would, in each record replay reads
where the behaviors depart from the recording, so that the judge compares bytes as ever.
It reads the baseline alongside the log, a part at a time, and hands its approved robot
states to the replay's :class:`~beatlog.replay.approved_states.ApprovedStateChecker` the
same way.
"""

from __future__ import annotations

import itertools
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from operator import attrgetter, itemgetter
from typing import Any

import msgspec

from beatlog.log.format import EMPTY_LIST, CycleRecord, LoggedStateChange, payload_encoder
from beatlog.replay.approved_states import ApprovedStateChecker
from beatlog.replay.baseline import (
    BaselinePart,
    BaselineStream,
    TracedOutput,
    changes_by_cycle,
)
from beatlog.replay.departures import ApprovedOutputs
from beatlog.replay.verdict import StateChange

__all__ = ["BaselineRecords"]

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
        queued_changes, queued_lines = self._changes, self._lines
        outputs = ApprovedOutputs(path)
        holding = False
        cycle = first
        if first:
            self._read_to(parts, first)
            while queued_changes and queued_changes[0][0] < first:
                queued_changes.popleft()
            while queued_lines and queued_lines[0][0] < first:
                holding = outputs.hold(queued_lines.popleft()[1])
        for batch in batches:
            start, end = cycle, cycle + len(batch)
            self._read_to(parts, end)
            if self._approved_states is not None:
                self._approved_states.forget(start)
            changes: dict[int, msgspec.Raw] = {}
            while queued_changes and queued_changes[0][0] < end:
                at, cycle_changes = queued_changes.popleft()
                changes[at] = self._encode_changes(cycle_changes)
            lines: dict[int, list[TracedOutput]] = {}
            while queued_lines and queued_lines[0][0] < end:
                at, cycle_lines = queued_lines.popleft()
                lines[at] = cycle_lines
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
