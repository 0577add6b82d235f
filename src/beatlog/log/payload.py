"""Decoding a session log's payloads: the header, the end record and batches of cycles.

Payloads are decoded only with msgspec, so nothing in a log can execute code. One that
does not decode is a :class:`~beatlog.errors.CorruptLogError` (a robot state that does
not fit its type: a :class:`~beatlog.errors.SchemaMismatchError`) naming the file and,
for a batch, the cycle at fault.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar, cast

import msgspec

from beatlog.errors import CorruptLogError, SchemaMismatchError
from beatlog.log.columns import StateColumns
from beatlog.log.format import (
    COLUMNS_SINCE,
    CYCLE_BATCH_SINCE,
    DECODE_ERRORS,
    ColumnBatch,
    CycleBatch,
    CycleRecord,
    LoggedStateChange,
    SessionHeader,
    samples_shape,
)

__all__ = [
    "BatchDecoding",
    "decode_outputs",
    "decode_part",
    "decode_payload",
    "decode_state_changes",
    "decoded_version",
]

T = TypeVar("T")


class _Versioned(msgspec.Struct):
    format_version: int


class _ReadCycleRecord(CycleRecord, forbid_unknown_fields=True):
    """A cycle record as the reader decodes it: one of more elements than the format
    defines is damaged, not cut short (the writer's own records stay as they are)."""


class _ReadCycleBatch(CycleBatch, forbid_unknown_fields=True):
    """A format-2 cycles message as the reader decodes it: nothing after its cycles."""

    cycles: list[_ReadCycleRecord]  # type: ignore[assignment]


class _ReadColumnBatch(ColumnBatch, forbid_unknown_fields=True):
    """A format-3 cycles message as the reader decodes it: nothing after its columns."""

    cycles: list[_ReadCycleRecord]  # type: ignore[assignment]
    data: memoryview = memoryview(b"")  # type: ignore[assignment]
    """A view of the message, not a copy (most of a wide log's bytes)."""


_NIL = msgspec.Raw(b"\xc0")
_COLUMN_BATCHES = msgspec.msgpack.Decoder(_ReadColumnBatch)
_CYCLE_BATCHES = msgspec.msgpack.Decoder(_ReadCycleBatch)
_RECORDS = msgspec.msgpack.Decoder(list[_ReadCycleRecord])
"""The cycles messages of each format, as read: made once, when the reader is loaded."""


class _RawBatch(msgspec.Struct, array_like=True):
    """A cycles message of format 2 with its cycles still encoded, to find a damaged one."""

    first_cycle: int
    cycles: list[msgspec.Raw]


def decode_payload(path: Path, data: bytes, kind: type[T], what: str) -> T:
    """``data`` decoded as ``kind``, or a corrupt log naming ``what`` was damaged."""
    try:
        return msgspec.msgpack.decode(data, type=kind)
    except DECODE_ERRORS as exc:
        raise CorruptLogError(path, f"damaged {what}: {exc}") from None


decode_state_changes = msgspec.msgpack.Decoder(list[LoggedStateChange]).decode
"""A cycle record's state changes (its ``state_changes`` part), decoded."""
decode_outputs = msgspec.msgpack.Decoder(dict[str, Any]).decode
"""A cycle record's outputs (its ``outputs`` part), decoded."""


def decode_part(
    path: Path,
    data: bytes | msgspec.Raw,
    decode: Callable[[bytes | msgspec.Raw], T],
    what: str,
    cycle: int,
) -> T:
    """``data``, a part of cycle ``cycle``'s record, decoded with ``decode``, or a corrupt
    log naming ``what`` was damaged in that cycle."""
    try:
        return decode(data)
    except DECODE_ERRORS as exc:
        raise CorruptLogError(path, f"damaged {what} in cycle {cycle}: {exc}") from None


def decoded_version(path: Path, data: bytes) -> int:
    """The format version a session header declares, read before the rest of it."""
    return decode_payload(path, data, _Versioned, "session header").format_version


class BatchDecoding:
    """How the cycles messages of one log decode (:attr:`decode`: into batches of records
    whose parts are raw msgpack, until :meth:`decode_states`), and what is wrong with
    one that does not."""

    def __init__(self, path: Path, header: SessionHeader) -> None:
        self.path = path
        self.header = header
        self._batched = header.format_version >= CYCLE_BATCH_SINCE
        self.columns = header.format_version >= COLUMNS_SINCE
        """Whether the log stores robot states by field (format 3): :meth:`records`."""
        decoder = _COLUMN_BATCHES if self.columns else _CYCLE_BATCHES if self._batched else _RECORDS
        self.skim: Callable[[bytes], Any] = decoder.decode
        """Decodes a message with every part of its records left as raw msgpack, and a
        format-3 batch's columns unread."""
        self.decode: Callable[[bytes], Any] = self.skim
        self._state_type: type[Any] | None = None
        self._checked: dict[tuple[bytes, bytes, int], list[int]] = {}

    def records(self, batch: ColumnBatch) -> list[CycleRecord]:
        """The cycles of a format-3 batch, its column table checked (:class:`StateColumns`):
        each record's ``robot_state`` is RS_t encoded whole, as format 2 holds it, or
        once :meth:`decode_states` was called, decoded (or the batch's
        :class:`StateColumns`, where it stores them by field).

        :raises beatlog.errors.CorruptLogError: a robot state stored by field is also
            in its record, or one stored in the records is missing.
        """
        records: list[CycleRecord] = batch.cycles
        decoded = self._state_type is not None
        if batch.state_fields is None:
            held: list[Any] = [r.robot_state for r in records] if decoded else []
            if None in held:
                raise SchemaMismatchError(
                    self.path,
                    f"robot state of cycle {batch.first_cycle + held.index(None)} does not "
                    f"fit {getattr(self._state_type, '__name__', self._state_type)}: it is nil",
                )
            return records
        columns = StateColumns(self.path, batch, self.header.state_fields, self._checked)
        states: list[Any] = [columns] * len(records) if decoded else columns.raw_states()
        nil = None if decoded else _NIL
        for offset, (record, state) in enumerate(zip(records, states, strict=True)):
            if record.robot_state != nil:
                raise CorruptLogError(
                    self.path,
                    f"damaged cycle {batch.first_cycle + offset}: its robot state is stored "
                    "by field, and in its record too",
                )
            record.robot_state = state
        return records

    def decode_states(self, state_type: type[Any]) -> None:
        """Make :attr:`decode` decode each cycle's RS_t into ``state_type`` and check its
        samples against the header (:func:`samples_shape`); in format 3 robot states
        stored by field stay in their columns (:meth:`records`)."""
        self._state_type = state_type
        samples, state = samples_shape(self.header), cast(Any, state_type)  # hashable
        rows = _state_decoder(state, samples, _ReadCycleBatch if self._batched else None)
        if not self.columns:
            self.decode = rows
            return
        # A batch whose records hold their states (2 items, as the writer writes it) is
        # a format-2 batch; another may hold nil states, checked as it is read.
        by_field = _state_decoder(state | None, samples, _ReadColumnBatch)
        self.decode = lambda data: rows(data) if data[:1] == b"\x92" else by_field(data)

    def problem(self, data: bytes, where: str, first_cycle: int, exc: Exception) -> Exception:
        """What is wrong with a batch that did not decode: a cycle in it is damaged, the
        batch itself is, or (when robot states are decoded with it) a cycle's robot state
        does not fit its type or its samples are not what the header declares."""
        try:
            decoded = self.skim(data)
        except DECODE_ERRORS as damage:
            return self._damaged_cycle(data, first_cycle) or CorruptLogError(
                self.path, f"damaged {where}: {damage}"
            )
        records: list[Any] = decoded if isinstance(decoded, list) else decoded.cycles
        by_field = isinstance(decoded, ColumnBatch) and decoded.state_fields is not None
        state_type = self._state_type
        assert state_type is not None  # raw records decoded: the states did not
        samples = samples_shape(self.header)
        for index, record in enumerate(records):
            try:
                if not by_field:
                    msgspec.msgpack.decode(record.robot_state, type=state_type)
            except DECODE_ERRORS as misfit:
                return SchemaMismatchError(
                    self.path,
                    f"robot state of cycle {first_cycle + index} does not fit "
                    f"{state_type.__name__}: {misfit}",
                )
            try:
                msgspec.msgpack.decode(record.samples, type=samples)
            except DECODE_ERRORS as misfit:
                logged = "samples" if self.header.samples_logged else "no samples"
                return CorruptLogError(
                    self.path,
                    f"damaged samples in cycle {first_cycle + index}: the header declares "
                    f"{logged}: {misfit}",
                )
        return CorruptLogError(self.path, f"damaged {where}: {exc}")

    def _damaged_cycle(self, data: bytes, first_cycle: int) -> CorruptLogError | None:
        """The first cycle of a batch that is not a cycle record, when the batch holds an
        array of cycles at all."""
        try:
            if self._batched:
                records = msgspec.msgpack.decode(data, type=_RawBatch).cycles
            else:
                records = msgspec.msgpack.decode(data, type=list[msgspec.Raw])
        except DECODE_ERRORS:
            return None
        for index, record in enumerate(records):
            try:
                msgspec.msgpack.decode(record, type=_ReadCycleRecord)
            except DECODE_ERRORS as damage:
                return CorruptLogError(self.path, f"damaged cycle {first_cycle + index}: {damage}")
        return None


# Made once for each, not once a replay: a whole replay of a 3-s rover log (101 cycles),
# after another, takes 30 % fewer instructions (6.9 M against 9.8 M, cachegrind).
@functools.lru_cache(maxsize=64)
def _state_decoder(state_type: Any, samples: Any, batch: Any) -> Callable[[bytes], Any]:
    """The decoding of a cycles message (a ``batch``, or None for a format-1 list of
    records) with each RS_t decoded as ``state_type`` and samples as ``samples``. Made
    once for each: a process replaying many short logs of one system reuses it."""
    record: Any = msgspec.defstruct(
        "DecodedCycleRecord",
        [("robot_state", state_type), ("samples", samples)],
        bases=(_ReadCycleRecord,),
        array_like=True,
    )
    if batch is None:
        return msgspec.msgpack.Decoder(list[record]).decode
    decoded = msgspec.defstruct(
        "DecodedCycleBatch", [("cycles", list[record])], bases=(batch,), array_like=True
    )
    return msgspec.msgpack.Decoder(decoded).decode
