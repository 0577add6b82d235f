"""A replayed log's cycle records read as the header declares them: RS_t decoded for the
system's robot state type, the samples, RN_t and the state changes, each checked;
anything else is a :class:`~beatlog.errors.CorruptLogError` naming the cycle. And the
behavior states a recording has at a cycle (:class:`RecordedStates`): what a window's
fresh start finds BS_t against.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import msgspec

from beatlog.errors import CorruptLogError
from beatlog.log.columns import StateColumns
from beatlog.log.format import (
    DECODE_ERRORS,
    EMPTY_LIST,
    CycleRecord,
    LoggedStateChange,
    SessionHeader,
    samples_shape,
)
from beatlog.log.payload import decode_part, decode_state_changes
from beatlog.model.inbox import Sample
from beatlog.model.random import Draw, recorded_draw_problem
from beatlog.replay.view import StateViews

__all__ = ["CycleReader", "RecordedStates", "recorded_changes"]


class CycleReader:
    """Reads the cycle records of the log at ``path`` with ``header``, RS_t through
    ``views``."""

    def __init__(self, header: SessionHeader, path: Path, views: StateViews) -> None:
        self.header = header
        self.path = path
        self._views = views
        self._draws = msgspec.msgpack.Decoder(list[Draw]).decode
        self._samples = msgspec.msgpack.Decoder(list[Sample]).decode
        self._samples_shape = msgspec.msgpack.Decoder(samples_shape(header)).decode

    def recorded_state(self, record: CycleRecord, cycle: int) -> Any:
        """RS_t of ``cycle`` as the log holds it, decoded for the system's robot state type
        (the reader may have decoded it with the batch:
        :meth:`~beatlog.log.reader.SessionLogReader.decode_states`).

        :raises beatlog.errors.SchemaMismatchError: it does not fit the type.
        """
        state: Any = record.robot_state
        if state.__class__ is StateColumns:
            return self._views.decode_whole(state.raw_state(cycle), cycle)
        if state.__class__ is not msgspec.Raw:
            return state
        return self._views.decode_whole(state, cycle)

    def samples(self, record: CycleRecord, cycle: int) -> list[Sample]:
        try:
            return self._samples(record.samples)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(self.path, f"damaged samples in cycle {cycle}: {exc}") from None

    def state(self, record: CycleRecord, cycle: int) -> Any:
        """RS_t of ``cycle`` decoded (:meth:`recorded_state`), its samples checked to be
        what the header declares, as
        :meth:`~beatlog.log.reader.SessionLogReader.decode_states` does with the batch."""
        state = self.recorded_state(record, cycle)
        try:
            self._samples_shape(record.samples)
        except DECODE_ERRORS as exc:
            logged = "samples" if self.header.samples_logged else "no samples"
            raise CorruptLogError(
                self.path,
                f"damaged samples in cycle {cycle}: the header declares {logged}: {exc}",
            ) from None
        return state

    def draws(self, record: CycleRecord, cycle: int) -> list[Draw]:
        """RN_t, each draw one a recording makes (:func:`recorded_draw_problem`)."""
        try:
            draws = self._draws(record.random_numbers)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(
                self.path, f"damaged random numbers in cycle {cycle}: {exc}"
            ) from None
        behaviors = len(self.header.behaviors)
        for number, draw in enumerate(draws, 1):
            problem = recorded_draw_problem(draw, behaviors)
            if problem is not None:
                raise CorruptLogError(
                    self.path, f"damaged random number #{number} in cycle {cycle}: {problem}"
                )
        return draws


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
    behavior's last state change's (a fresh start's, see
    :class:`~beatlog.replay.session.ReplaySession`)."""

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
