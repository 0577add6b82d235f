"""A replayed log's cycle records read as the header declares them: RS_t decoded for the
system's robot state type, the samples and RN_t, each checked; anything else is a
:class:`~beatlog.errors.CorruptLogError` naming the cycle."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import msgspec

from beatlog.errors import CorruptLogError
from beatlog.log.columns import StateColumns
from beatlog.log.format import DECODE_ERRORS, CycleRecord, SessionHeader, samples_shape
from beatlog.model.inbox import Sample
from beatlog.model.random import Draw, recorded_draw_problem
from beatlog.replay.view import StateViews

__all__ = ["CycleReader"]


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
