"""The columnar layout of format 3: a batch's robot states stored field by field.

The writer turns a batch of encoded cycles into a :class:`~beatlog.log.format.ColumnBatch`
(:func:`column_batch`): the cycle records without their robot states in one column, and
each robot-state field's values, in cycle order, in a column of its own, compressed
apart where that makes it smaller. A reader opens a batch as :class:`StateColumns`,
which checks every column's size against the batch's cycle count without decoding a
value, and decodes a column only when it is asked for it: a replay whose behaviors read
30 of 1,000 fields decodes 30 columns. The values are the bytes the writer was given,
so a robot state put back together (:meth:`StateColumns.raw_states`) is byte for byte
the one a format-2 log holds.
"""

from __future__ import annotations

import re
import struct
import threading
from collections.abc import Callable, Sequence
from itertools import accumulate
from pathlib import Path
from typing import Any

import msgspec
import zstandard

from beatlog.errors import CorruptLogError, SchemaMismatchError
from beatlog.log.format import DECODE_ERRORS, Column, ColumnBatch
from beatlog.log.limits import MAX_CHUNK_BYTES, MAX_VALUE_WIDTH

__all__ = ["StateColumns", "array_head", "column_batches", "decompressed", "encode_column"]

PLAIN, ZSTD = 0, 1
"""A column's codec: its bytes as they are, or one zstd frame of them."""
_COMPRESSION_LEVEL = 3


def array_head(count: int) -> bytes:
    """The msgpack head of an array of ``count`` values (as msgspec writes it)."""
    if count < 16:
        return bytes([0x90 | count])
    if count < 1 << 16:
        return b"\xdc" + count.to_bytes(2, "big")
    return b"\xdd" + count.to_bytes(4, "big")


def encode_column(values: Sequence[Any], compress: Callable[[bytes], bytes]) -> Column:
    """A column of ``values`` (each a value's msgpack bytes): byte-split where all are
    the same width, zstd-compressed where that is smaller."""
    widths = set(map(len, values))
    body = b"".join(values)
    width = widths.pop() if len(widths) == 1 else 0
    if 1 < width <= MAX_VALUE_WIDTH:
        data = b"".join([body[k::width] for k in range(width)])
    else:
        width = width if width == 1 else 0
        data = body
    packed = compress(data)
    return Column(ZSTD, width, packed) if len(packed) < len(data) else Column(PLAIN, width, data)


_FIELDS = msgspec.msgpack.Decoder(dict[str, msgspec.Raw]).decode
_FRAME = zstandard.FORMAT_ZSTD1_MAGICLESS
"""A column's zstd frame is written without the 4 bytes of magic number every frame
would repeat: a column's codec already says it is one."""


def _compressor() -> zstandard.ZstdCompressor:
    parameters = zstandard.ZstdCompressionParameters.from_level(
        _COMPRESSION_LEVEL, format=_FRAME, write_content_size=True, write_checksum=False
    )
    return zstandard.ZstdCompressor(compression_params=parameters)


def column_batches(
    first_cycle: int,
    records: Sequence[bytes],
    states: Sequence[bytes],
    header_fields: Sequence[str] = (),
) -> list[tuple[int, ColumnBatch]]:
    """Batches of format 3 from consecutive cycles' records (each encoded with a nil robot
    state) and robot states (each encoded whole), with where each starts among them.

    A batch holds states of the same fields in the same order; a state of other fields
    (a type that omits defaults) starts the next. A batch of the ``header_fields`` names
    none. A state that is not a map of named fields is stored whole, in a batch of such
    states.
    """
    compress = _compressor().compress
    rows = [_fields(state) for state in states]
    batches: list[tuple[int, ColumnBatch]] = []
    start = 0
    for end in range(1, len(rows) + 1):
        if end < len(rows) and _same_fields(rows[end], rows[start]):
            continue
        cycles = encode_column(records[start:end], compress)
        first = rows[start]
        if first is None:
            names = None
            columns = [encode_column(states[start:end], compress)]
        else:
            values = zip(*[row.values() for row in rows[start:end]], strict=True)
            columns = [encode_column(column, compress) for column in values]
            names = list(first)
            names = [] if names == header_fields else names
        batch = ColumnBatch(
            first_cycle + start,
            end - start,
            cycles,
            names,
            bytes([column.codec for column in columns]),
            bytes([column.width for column in columns]),
            struct.pack(f"<{len(columns)}I", *[len(column.data) for column in columns]),
            b"".join([column.data for column in columns]),
        )
        batches.append((start, batch))
        start = end
    return batches


def _fields(state: bytes) -> dict[str, msgspec.Raw] | None:
    """An encoded robot state's fields, each still encoded; None where it is not a map
    of named fields."""
    try:
        return _FIELDS(state)
    except msgspec.DecodeError:
        return None


def _same_fields(one: dict[str, Any] | None, other: dict[str, Any] | None) -> bool:
    if one is None or other is None:
        return one is other
    return len(one) == len(other) and all(map(str.__eq__, one, other))


_THREAD = threading.local()


def _decompressor() -> zstandard.ZstdDecompressor:
    """This thread's decompressor of column frames (one may not serve two threads)."""
    found: zstandard.ZstdDecompressor | None = getattr(_THREAD, "decompressor", None)
    if found is None:
        found = _THREAD.decompressor = zstandard.ZstdDecompressor(format=_FRAME)
    return found


class _Values(msgspec.Struct, array_like=True, gc=False):
    """Any array: decoding a column as this walks its values without building them."""


_WALK = msgspec.msgpack.Decoder(_Values).decode
_AT = re.compile(r"at `\$\[(\d+)\]")


def decompressed(data: bytes, size: int, what: str) -> bytes:
    """The zstd frame ``data`` decompressed, exactly ``size`` bytes."""
    try:
        opened = _decompressor().decompress(data, max_output_size=size)
    except zstandard.ZstdError as exc:
        raise ValueError(f"{what} does not decompress: {exc}") from None
    if len(opened) != size:
        raise ValueError(f"{what} holds {len(opened)} bytes where it declares {size}")
    return opened


class StateColumns:
    """One format-3 batch, its columns decoded only when asked for.

    Opening checks the batch's shape: a column per field, no field named twice. A
    column is checked the first time it is read: its size must be its values' (its
    width times the cycles), a compressed column must declare that size (within
    :data:`~beatlog.log.limits.MAX_CHUNK_BYTES`) and hold it, and a column of values of
    varied width must hold exactly one value per cycle. So a damaged column is an error
    wherever something reads it (replay reads the fields its behaviors read; anything
    that shows whole states reads them all), and the chunk's CRC covers every byte of
    all of them. ``spend`` is told every byte decompressed, to stop a decompression bomb.
    Robot-state columns are numbered from 0 in :attr:`names` order.

    :raises beatlog.errors.CorruptLogError: the batch does not have a column per field.
    """

    def __init__(
        self,
        path: Path,
        batch: ColumnBatch,
        header_fields: list[str],
        spend: Callable[[int], None],
    ) -> None:
        self.path = path
        self.first_cycle = batch.first_cycle
        self.count = batch.count
        names = batch.state_fields
        self.names = header_fields if names == [] else names
        """The fields' names in column order; None where the column holds whole states."""
        self._spend = spend
        self._bodies: dict[int, bytes] = {}
        self._batch = batch
        expected = 1 if self.names is None else len(self.names)
        if (len(batch.codecs), len(batch.widths), len(batch.sizes)) != (expected,) * 2 + (
            4 * expected,
        ):
            raise self._damaged(f"the column table does not describe {expected} columns")
        if names is not None and names != [] and len(set(names)) != len(names):
            raise self._damaged("a field is named twice")
        self._ends = list(accumulate(struct.unpack(f"<{expected}I", batch.sizes)))
        if (self._ends[-1] if self._ends else 0) != len(batch.data):
            raise self._damaged(
                f"its columns take {self._ends[-1] if self._ends else 0} bytes, "
                f"not the {len(batch.data)} it holds"
            )
        self._records = expected

    def _column(self, index: int) -> Column:
        """Column ``index`` (the cycle records after the robot state's), its bytes in place."""
        batch = self._batch
        if index == self._records:
            return batch.cycles
        start = self._ends[index - 1] if index else 0
        return Column(batch.codecs[index], batch.widths[index], batch.data[start : self._ends[index]])

    def name(self, index: int) -> str:
        """What a column holds: a field, whole robot states, or the cycle records."""
        if index == self._records:
            return "cycle records"
        return "robot state" if self.names is None else f"field {self.names[index]!r}"

    def _damaged(self, problem: str) -> CorruptLogError:
        return CorruptLogError(self.path, f"damaged batch from cycle {self.first_cycle}: {problem}")

    def _size(self, column: Column, index: int) -> int:
        """A column's size uncompressed, checked against its width and the cycles."""
        if column.codec not in (PLAIN, ZSTD) or column.width > MAX_VALUE_WIDTH:
            raise self._damaged(
                f"{self.name(index)} has codec {column.codec} and width {column.width}"
            )
        size = len(column.data)
        if column.codec == ZSTD:
            try:
                size = zstandard.get_frame_parameters(column.data, format=_FRAME).content_size
            except zstandard.ZstdError as exc:
                raise self._damaged(f"{self.name(index)}: not a zstd frame: {exc}") from None
            if size > MAX_CHUNK_BYTES:
                raise self._damaged(f"{self.name(index)} declares no size or {size} bytes")
        if column.width and size != column.width * self.count:
            raise self._damaged(
                f"{self.name(index)} holds {size} bytes, not {self.count} values of "
                f"{column.width} bytes (a value missing, repeated or foreign)"
            )
        return size

    def _body(self, index: int) -> bytes:
        """A column's values' msgpack bytes back to back, checked, decompressed and
        un-split."""
        body = self._bodies.get(index)
        if body is not None:
            return body
        column = self._column(index)
        size = self._size(column, index)
        data: Any = column.data
        if column.codec == ZSTD:
            self._spend(size)
            try:
                data = decompressed(data, size, self.name(index))
            except ValueError as exc:
                raise self._damaged(str(exc)) from None
        width = column.width
        if width > 1:
            split = bytearray(size)
            count = self.count
            for k in range(width):
                split[k::width] = data[k * count : (k + 1) * count]
            data = bytes(split)
        else:
            data = bytes(data)
        self._bodies[index] = data
        if width == 0 and index < self._records:  # records: checked as decoded
            self._walk(index)
        return data

    def encoded(self, index: int) -> bytes:
        """A column as one msgpack array of the batch's values."""
        return array_head(self.count) + self._body(index)

    def _walk(self, index: int) -> None:
        """Check that a column of values of varied width holds exactly one per cycle."""
        try:
            _WALK(self.encoded(index))
        except DECODE_ERRORS as exc:
            del self._bodies[index]
            raise self._damaged(
                f"{self.name(index)} does not hold {self.count} values (a value missing, "
                f"repeated or foreign): {exc}"
            ) from None

    def records(self, decode: Callable[[bytes], list[Any]]) -> list[Any]:
        """The batch's cycle records, decoded with ``decode``.

        :raises beatlog.errors.CorruptLogError: a record does not decode (naming its cycle).
        """
        try:
            return decode(self.encoded(self._records))
        except DECODE_ERRORS as exc:
            raise CorruptLogError(self.path, f"damaged cycle {self._cycle(exc)}: {exc}") from None

    def values(self, index: int, decode: Callable[[bytes], list[Any]], type_name: str) -> list[Any]:
        """A robot-state column's values decoded with ``decode`` (for a list of the
        field's type).

        :raises beatlog.errors.SchemaMismatchError: a value does not fit the field's type
            (the message names its cycle and the field).
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

    def _cycle(self, exc: Exception) -> int:
        """The cycle a decoding error points at (the batch's first when it says none)."""
        found = _AT.search(str(exc))
        return self.first_cycle + (int(found.group(1)) if found else 0)

    def _raw_columns(self) -> list[list[msgspec.Raw]]:
        return [_RAWS(self.encoded(index)) for index in range(self._records)]

    def raw_states(self) -> list[msgspec.Raw]:
        """Every cycle's RS_t encoded whole, as a format-2 log holds it."""
        columns = self._raw_columns()
        if self.names is None:
            return columns[0]
        if not columns:
            return [msgspec.Raw(b"\x80")] * self.count
        encode = _ENCODER.encode
        names = self.names
        return [msgspec.Raw(encode(dict(zip(names, row, strict=True)))) for row in zip(*columns)]

    def raw_state(self, cycle: int) -> msgspec.Raw:
        """RS_t of ``cycle`` (one of the batch's) encoded whole, as a format-2 log holds it."""
        at = cycle - self.first_cycle
        values = [column[at] for column in self._raw_columns()]
        if self.names is None:
            return values[0]
        return msgspec.Raw(_ENCODER.encode(dict(zip(self.names, values, strict=True))))


_RAWS = msgspec.msgpack.Decoder(list[msgspec.Raw]).decode
_ENCODER = msgspec.msgpack.Encoder()
