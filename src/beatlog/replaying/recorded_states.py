"""The behavior states a recording has at a cycle, read from the state changes before
it: what a window's fresh start finds BS_t against
(:class:`~beatlog.replaying.session.ReplaySession`), so that a behavior whose fresh
state is the recorded one shows no change there."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from beatlog.errors import CorruptLogError
from beatlog.log.format import EMPTY_LIST, CycleRecord
from beatlog.log.payload import decode_part, decode_state_changes

__all__ = ["RecordedStates"]


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
                changes = decode_part(
                    self._path, record.state_changes, decode_state_changes, "state changes", cycle
                )
                for index, _, after in changes:
                    if not 0 <= index < len(self._behaviors):
                        raise CorruptLogError(
                            self._path,
                            f"damaged state changes in cycle {cycle}: behavior #{index} is "
                            f"not in the catalogue of {len(self._behaviors)}",
                        )
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
