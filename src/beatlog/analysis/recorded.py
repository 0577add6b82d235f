"""What a log recorded, gathered batch by batch: its state changes, by the log's
behavior catalogue, for the transition coverage. A :class:`RecordedChanges` reads
the batches a replay session reads (the verdict's own, in a suite run), or a log of
its own (:func:`read_changes`)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import msgspec

from beatlog.log.format import EMPTY_LIST, CycleRecord
from beatlog.log.payload import decode_part, decode_state_changes
from beatlog.log.reader import SessionLogReader
from beatlog.log.recording import LogSource
from beatlog.replay.baseline import TracedStateChange
from beatlog.replay.verdict import StateChange

__all__ = ["RecordedChanges", "named_changes", "read_changes"]


class RecordedChanges:
    """The state changes a log recorded, named by its behavior catalogue, and its cycles,
    gathered from its batches in order (:meth:`read`); ``system`` names its system for
    coverage: the ``module:factory`` its header records, else its robot-state type."""

    def __init__(self, reader: SessionLogReader) -> None:
        header = reader.header
        self.reference = header.system
        """The ``module:factory`` the header records, if any."""
        self.system = header.system or header.robot_state_type
        self.changes: list[TracedStateChange] = []
        self.cycles = 0
        self._names = header.behaviors
        self._path = reader.path
        self._time_ns = 0

    def read(self, batch: Sequence[CycleRecord]) -> None:
        """Take the log's next batch.

        :raises beatlog.errors.CorruptLogError: a cycle's state changes are damaged.
        """
        names, changes = self._names, self.changes
        for record in batch:
            self._time_ns += record.heartbeat_ns
            if record.state_changes != EMPTY_LIST:
                changes.extend(
                    TracedStateChange(self.cycles, self._time_ns, change)
                    for change in named_changes(
                        self._path, record.state_changes, names, self.cycles
                    )
                )
            self.cycles += 1


def named_changes(
    path: Path, raw: msgspec.Raw, names: Sequence[str], cycle: int
) -> list[StateChange]:
    """The state changes cycle ``cycle`` recorded, each behavior named by the log's
    catalogue ``names`` (``#N`` for an index outside it).

    :raises beatlog.errors.CorruptLogError: they are damaged.
    """
    return [
        StateChange(names[index] if 0 <= index < len(names) else f"#{index}", before, after)
        for index, before, after in decode_part(
            path, raw, decode_state_changes, "state changes", cycle
        )
    ]


def read_changes(log: LogSource) -> RecordedChanges:
    """Every state change ``log`` recorded, and how many cycles it holds."""
    with SessionLogReader(log) as reader:
        recorded = RecordedChanges(reader)
        for batch in reader.batches():
            recorded.read(batch)
    return recorded
