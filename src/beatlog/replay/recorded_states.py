"""The behavior states a recording has at a cycle, read from the state changes before
it: what a window's fresh start finds BS_t against
(:class:`~beatlog.replay.session.ReplaySession`), so that a behavior whose fresh
state is the recorded one shows no change there."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import msgspec

from beatlog.errors import CorruptLogError
from beatlog.log.format import EMPTY_LIST, CycleRecord, LoggedStateChange
from beatlog.log.payload import decode_part, decode_state_changes

__all__ = ["RecordedStates", "recorded_changes"]


def recorded_changes(
    path: Path, raw: msgspec.Raw, cycle: int, catalogue: int
) -> list[LoggedStateChange]:
    """The state changes recorded in ``cycle``, decoded.

    :raises beatlog.errors.CorruptLogError: they are damaged, or one names a behavior
        past the catalogue's ``catalogue`` behaviors.
    """
    changes = decode_part(path, raw, decode_state_changes, "state changes", cycle)
    for index, _, _ in changes:
        if not 0 <= index < catalogue:
            raise CorruptLogError(
                path,
                f"damaged state changes in cycle {cycle}: behavior #{index} is not in the "
                f"catalogue of {catalogue}",
            )
    return changes


class RecordedStates:
    """The behavior states a recording has after the cycles it is handed: each
    behavior's last state change's (a fresh start's, see :class:`ReplaySession`)."""

    def __init__(self, path: Path, behaviors: Sequence[str]) -> None:
        self._path = path
        self._behaviors = behaviors
        self._cycle = 0
        self._last: dict[int, Any] = {}

    def take(self, batch: Sequence[CycleRecord]) -> None:
        """Take the next cycles, as recorded.

        :raises beatlog.errors.CorruptLogError: their state changes are damaged.
        """
        last, cycle = self._last, self._cycle
        for record in batch:
            if record.state_changes != EMPTY_LIST:
                changes = recorded_changes(
                    self._path, record.state_changes, cycle, len(self._behaviors)
                )
                for index, _, after in changes:
                    last[index] = after
            cycle += 1
        self._cycle = cycle

    def by_position(self, behaviors: Sequence[str], rename: Callable[[str], str]) -> dict[int, Any]:
        """The states by position in ``behaviors`` (a system's catalogue), each recorded
        behavior's name mapped by ``rename``; a behavior the system lacks is left out."""
        position = {name: index for index, name in enumerate(behaviors)}
        return {
            position[name]: state
            for index, state in self._last.items()
            if (name := rename(self._behaviors[index])) in position
        }
