"""The columnar layout of format 3: a batch's robot states stored field by field.

The writer turns consecutive encoded cycles into
:class:`~beatlog.log.format.ColumnBatch` messages (:func:`column_batches`): the records
without their robot states, and each robot-state field's values in a column of its own.
A reader opens a batch as :class:`StateColumns`, which checks its column table and
decodes a column only when asked for it: a replay whose behaviors read 30 of 1,000
fields decodes 30 columns. A robot state put back together is byte for byte the one a
format-2 log holds.

A column of values of one width (a float field: 9 bytes each) is stored byte-split
(byte 0 of every value, then byte 1, ...), so that zstd finds a float column's marker
and exponent bytes side by side. A log whose header names no robot-state fields keeps
its robot states in the records, as format 2 does: the recorder names them for a state
of at least :data:`COLUMNS_FROM` fields.
"""

from __future__ import annotations

import re
import struct
from collections.abc import Callable, Iterable, Sequence
from itertools import accumulate
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from beatlog.errors import CorruptLogError, SchemaMismatchError
from beatlog.log.format import DECODE_ERRORS, ColumnBatch
from beatlog.log.limits import MAX_VALUE_WIDTH

__all__ = [
    "COLUMNS_FROM",
    "Column",
    "StateColumns",
    "array_head",
    "column_batches",
    "encode_column",
]

COLUMNS_FROM = 100
"""The fewest fields a robot state has for the recorder to have it stored by field:
with 30 fields read, replay by field costs a little less than from the records at 100
fields, and a little more at 80."""


class Column(NamedTuple):
    """One robot-state field's values, one a cycle, as bytes (``docs/format.md``)."""

    width: int
    """0: the values' msgpack encodings back to back; W > 0: each value is W bytes,
    stored byte-split (byte 0 of every value, then byte 1 of every value, ...)."""
    data: bytes


def array_head(count: int) -> bytes:
    """The msgpack head of an array of ``count`` values (as msgspec writes it)."""
    if count < 16:
        return bytes([0x90 | count])
    if count < 1 << 16:
        return b"\xdc" + count.to_bytes(2, "big")
    return b"\xdd" + count.to_bytes(4, "big")


def encode_column(values: Sequence[Any]) -> Column:
    """A column of ``values`` (each a value's msgpack bytes), byte-split where all are
    the same width (at most :data:`~beatlog.log.limits.MAX_VALUE_WIDTH`)."""
    widths = set(map(len, values))
    body = b"".join(values)
    width = widths.pop() if len(widths) == 1 else 0
    if width > MAX_VALUE_WIDTH:
        return Column(0, body)
    if width > 1:
        return Column(width, b"".join([body[k::width] for k in range(width)]))
    return Column(width, body)


_FIELDS = msgspec.msgpack.Decoder(dict[str, msgspec.Raw]).decode
"""An encoded robot state's fields, each still encoded."""


def column_batches(
    first_cycle: int,
    records: Sequence[bytes],
    states: Sequence[bytes],
    header_fields: Sequence[str] = (),
) -> list[tuple[int, ColumnBatch]]:
    """Batches of format 3 from consecutive cycles' records (each encoded with a nil robot
    state) and robot states (each a map of named fields), with where each starts.

    A batch holds states of the same fields in the same order (a type that omits
    defaults may change them); one of the ``header_fields`` names none; states of no
    field at all stay in their records.

    :raises msgspec.DecodeError: a robot state is not a map of named fields.
    """
    rows = [_FIELDS(state) for state in states]
    header = list(header_fields)
    batches: list[tuple[int, ColumnBatch]] = []
    start = 0
    for end in range(1, len(rows) + 1):
        if end < len(rows) and list(rows[end]) == list(rows[start]):
            continue
        names = list(rows[start])
        if not names:  # no field to store by: the states stay in their records
            held = zip(records[start:end], states[start:end], strict=True)
            cycles: list[Any] = [_with_state(record, state) for record, state in held]
            batch = ColumnBatch(first_cycle + start, cycles)
        else:
            values = zip(*[row.values() for row in rows[start:end]], strict=True)
            columns = [encode_column(column) for column in values]
            batch = ColumnBatch(
                first_cycle + start,
                [msgspec.Raw(record) for record in records[start:end]],  # type: ignore[misc]
                [] if names == header else names,
                bytes([column.width for column in columns]),
                struct.pack(f"<{len(columns)}I", *[len(column.data) for column in columns]),
                b"".join([column.data for column in columns]),
            )
        batches.append((start, batch))
        start = end
    return batches


def _with_state(record: bytes, state: bytes) -> msgspec.Raw:
    """A record encoded with a nil robot state, holding ``state`` instead."""
    parts = _RAWS(record)
    parts[1] = msgspec.Raw(state)
    return msgspec.Raw(_ENCODER.encode(parts))


_AT = re.compile(r"at `\$\[(\d+)\]")


class _Values(msgspec.Struct, array_like=True, gc=False):
    """Any array: decoding a column as this walks its values without building them."""


_WALK = msgspec.msgpack.Decoder(_Values).decode
_CHECKED_TABLES = 256
"""Column tables (widths, sizes, cycles) a reader remembers as checked, with where each
column ends: consecutive batches of one robot mostly share theirs. Checking each table
afresh costs 21 % more instructions on a whole replay of 10 behaviors reading 3 fields
each of a 1,000-field robot state (665.2 M against 551.6 M for 3,000 cycles; 2.8 % at
100 behaviors: 733.9 M against 713.6 M for 600)."""


class StateColumns:
    """One format-3 batch, its columns decoded only when asked for.

    Opening checks, without decoding a value, that each column holds exactly one value
    a cycle (a column table already seen is checked once: ``checked`` keeps each one's
    column ends); a value's type is checked when its column is decoded. Robot-state
    columns are numbered from 0 in :attr:`names` order.

    :raises beatlog.errors.CorruptLogError: a column does not hold one value a cycle.
    """

    def __init__(
        self,
        path: Path,
        batch: ColumnBatch,
        header_fields: list[str],
        checked: dict[tuple[bytes, bytes, int], list[int]] | None = None,
    ) -> None:
        self.path = path
        self.first_cycle = batch.first_cycle
        self.count = len(batch.cycles)
        names = batch.state_fields
        self.names = header_fields if names == [] else names
        """The fields' names in column order; None where the records hold the states."""
        # Not the batch itself: its records hold this, and a cycle of references would
        # keep every batch read alive until the garbage collector found it.
        self.widths = batch.widths
        """Each column's width: that of all its values, 0 where they vary."""
        self._data = batch.data
        self._encoded: dict[int, bytes] = {}
        expected = 0 if self.names is None else len(self.names)
        if (len(batch.widths), len(batch.sizes)) != (expected, 4 * expected):
            raise self._damaged(f"its column table does not describe {expected} columns")
        if names and len(set(names)) != len(names):
            raise self._damaged("a field is named twice")
        table = (batch.widths, batch.sizes, self.count)
        known = None if checked is None else checked.get(table)
        sizes = struct.unpack(f"<{expected}I", batch.sizes) if known is None else ()
        self._ends = ends = list(accumulate(sizes)) if known is None else known
        held = ends[-1] if ends else 0
        if held != len(batch.data):
            raise self._damaged(
                f"its columns take {held} bytes, not the {len(batch.data)} it holds"
            )
        if known is None:
            self._check_sizes(sizes)
            if checked is not None and len(checked) < _CHECKED_TABLES:
                checked[table] = ends
        index = batch.widths.find(0)
        while index >= 0:  # the columns of values of varied width
            self._walk(index)
            index = batch.widths.find(0, index + 1)

    def _check_sizes(self, sizes: tuple[int, ...]) -> None:
        """Every column of values of one width must hold exactly one value a cycle."""
        count = self.count
        for index, (width, size) in enumerate(zip(self.widths, sizes, strict=True)):
            if width > MAX_VALUE_WIDTH or (width and size != width * count):
                raise self._damaged(
                    f"{self.name(index)} holds {size} bytes, not {count} values of {width} "
                    "bytes (a value missing, repeated or foreign)"
                )

    def name(self, index: int) -> str:
        """The field a column holds."""
        return f"field {(self.names or [])[index]!r}"

    def _damaged(self, problem: str) -> CorruptLogError:
        return CorruptLogError(self.path, f"damaged batch from cycle {self.first_cycle}: {problem}")

    def encoded(self, index: int) -> bytes:
        """A column as one msgpack array of the batch's values, un-split (once; kept for
        the batch)."""
        self.unsplit((index,))
        return self._encoded[index]

    def unsplit(self, indices: Iterable[int]) -> None:
        """Make the columns ``indices`` msgpack arrays (:meth:`encoded`), a byte-split
        one put back together a byte of its values at a time."""
        count = self.count
        head = array_head(count)
        for index in indices:
            if index in self._encoded:
                continue
            width = self.widths[index]
            start = self._ends[index - 1] if index else 0
            column: Any = self._data[start : self._ends[index]]
            if width > 1:
                values = bytearray(len(column))
                for byte in range(width):
                    values[byte::width] = column[byte * count : (byte + 1) * count]
                column = values
            self._encoded[index] = head + column

    def rows(self, fixed: Sequence[int], varied: Sequence[int] = ()) -> list[bytes]:
        """Each cycle of the batch as one msgpack array of its values in the columns
        ``fixed`` (each of values of one width), then ``varied`` (of varied width): with
        the ``fixed`` columns' planes laid end to end, a cycle's values are one strided
        slice.

        :raises msgspec.DecodeError: a column of varied width is damaged.
        """
        count = self.count
        ends = [0, *self._ends]
        data = memoryview(self._data)
        planes: list[bytes | memoryview] = [
            bytes([byte]) * count for byte in array_head(len(fixed) + len(varied))
        ]
        start = end = 0
        for index in fixed:
            if ends[index] != end:
                planes.append(data[start:end])
                start = ends[index]
            end = ends[index + 1]
        planes.append(data[start:end])
        group = b"".join(planes)
        rows = [group[cycle::count] for cycle in range(count)]
        if not varied:
            return rows
        self.unsplit(varied)
        encoded = self._encoded
        values = [_RAWS(encoded[index]) for index in varied]
        return list(map(b"".join, zip(rows, *values, strict=True)))

    def _walk(self, index: int) -> None:
        """A column of values of varied width must hold exactly one value a cycle."""
        try:
            _WALK(self.encoded(index))
        except DECODE_ERRORS as exc:
            raise self._damaged(
                f"{self.name(index)} does not hold {self.count} values (a value missing, "
                f"repeated or foreign): {exc}"
            ) from None

    def values(self, index: int, decode: Callable[[Any], list[Any]], type_name: str) -> list[Any]:
        """A robot-state column's values decoded with ``decode``.

        :raises beatlog.errors.SchemaMismatchError: a value does not fit the field's type.
        :raises beatlog.errors.CorruptLogError: the column is damaged.
        """
        try:
            return decode(self.encoded(index))
        except msgspec.ValidationError as exc:
            raise SchemaMismatchError(
                self.path,
                f"robot state of cycle {self._cycle(exc)} does not fit {type_name}: "
                f"{self.name(index)}: {exc}",
            ) from None
        except DECODE_ERRORS as exc:
            raise CorruptLogError(
                self.path, f"damaged {self.name(index)} in cycle {self._cycle(exc)}: {exc}"
            ) from None

    def decoded(
        self, indices: list[int], decoders: list[Callable[[Any], list[Any]]], type_name: str
    ) -> list[list[Any]]:
        """The columns ``indices`` decoded, each with its decoder, as :meth:`values` decodes
        (and refuses) one."""
        columns = zip(indices, decoders, strict=True)
        return [self.values(index, decode, type_name) for index, decode in columns]

    def _cycle(self, exc: Exception) -> int:
        """The cycle a decoding error points at (the batch's first when it says none)."""
        found = _AT.search(str(exc))
        return self.first_cycle + (int(found.group(1)) if found else 0)

    def _raw_columns(self) -> list[list[msgspec.Raw]]:
        columns = []
        for index in range(len(self._ends)):
            try:
                columns.append(_RAWS(self.encoded(index)))
            except DECODE_ERRORS as exc:
                raise self._damaged(f"{self.name(index)}: {exc}") from None
        return columns

    def raw_states(self) -> list[msgspec.Raw]:
        """Every cycle's RS_t encoded whole, as a format-2 log holds it.

        :raises beatlog.errors.CorruptLogError: a column is damaged.
        """
        columns = self._raw_columns()
        rows = zip(*columns, strict=True) if columns else [()] * self.count
        return [self._whole(row) for row in rows]

    def raw_state(self, cycle: int) -> msgspec.Raw:
        """RS_t of ``cycle`` (one of the batch's) encoded whole, as a format-2 log holds it.

        :raises beatlog.errors.CorruptLogError: a column is damaged.
        """
        return self._whole([column[cycle - self.first_cycle] for column in self._raw_columns()])

    def _whole(self, values: Sequence[msgspec.Raw]) -> msgspec.Raw:
        return msgspec.Raw(_ENCODER.encode(dict(zip(self.names or (), values, strict=True))))


_RAWS = msgspec.msgpack.Decoder(list[msgspec.Raw]).decode
_ENCODER = msgspec.msgpack.Encoder()
