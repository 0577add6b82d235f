"""Byte-level reading of a session log's MCAP container: records, chunks, the summary.

All reading of the container's bytes happens here, with the ``mcap`` package's record
types. The container knows nothing of payload encodings (:mod:`beatlog.log.payload`)
nor of what makes a log whole (:mod:`beatlog.log.integrity`); a record not as the
format defines it is a :class:`RecordDamageError`.
"""

from __future__ import annotations

import struct
import zlib
from io import BytesIO
from typing import Any

import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    McapRecord,
    Message,
    MessageIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

from beatlog.log.limits import MAX_CHUNK_BYTES

__all__ = [
    "CHUNK_RECORDS",
    "DATA_RECORDS",
    "FOOTER_BYTES",
    "FOOTER_RECORD",
    "KNOWN_OPCODES",
    "MAGIC",
    "RECORD_HEAD",
    "SUMMARY_RECORDS",
    "RecordDamageError",
    "read_record",
    "split_records",
    "unpack_chunk",
]

MAGIC = b"\x89MCAP0\r\n"
RECORD_HEAD = 9
"""A record's opcode (1 byte) and the length of its body (8)."""
FOOTER_BYTES = 20
"""A footer's body: where the summary and its offsets start (8 bytes each), its CRC (4)."""
FOOTER_RECORD = RECORD_HEAD + FOOTER_BYTES
KNOWN_OPCODES = frozenset(Opcode)
DATA_RECORDS = frozenset({Opcode.CHUNK, Opcode.MESSAGE_INDEX, Opcode.DATA_END})
SUMMARY_RECORDS = frozenset(
    {Opcode.SCHEMA, Opcode.CHANNEL, Opcode.STATISTICS, Opcode.CHUNK_INDEX, Opcode.SUMMARY_OFFSET}
)
CHUNK_RECORDS = frozenset({Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE})
_COMPRESSIONS = ("", "zstd")
_U16, _U32, _U64 = struct.Struct("<H"), struct.Struct("<I"), struct.Struct("<Q")
_RECORD_TYPES: dict[int, type[McapRecord]] = {
    Opcode.HEADER: Header,
    Opcode.CHUNK: Chunk,
    Opcode.CHUNK_INDEX: ChunkIndex,
    Opcode.MESSAGE: Message,
    Opcode.MESSAGE_INDEX: MessageIndex,
    Opcode.DATA_END: DataEnd,
    Opcode.SCHEMA: Schema,
    Opcode.CHANNEL: Channel,
    Opcode.STATISTICS: Statistics,
    Opcode.SUMMARY_OFFSET: SummaryOffset,
    Opcode.FOOTER: Footer,
}


class RecordDamageError(Exception):
    """A record is not what the writer writes; the log package's readers turn it into a
    :class:`~beatlog.errors.LogError` naming the file, or a truncation where it is last."""


class _Fields(ReadDataStream):
    """A record's body read field by field, each field whole: one cut short is damage.
    Read in place, one unpack a field: mcap's own stream over a copy of the body makes a
    whole replay of a 100- to 10,000-cycle log 4 to 7 % slower (tests/log/test_container.py
    pins the two alike)."""

    def __init__(self, body: bytes) -> None:
        super().__init__(BytesIO())
        self._body = body
        self._position = 0

    @property
    def count(self) -> int:
        """How many bytes of the body have been read."""
        return self._position

    def _take(self, length: int) -> int:
        """Where the next ``length`` bytes start, once they are known to be there."""
        start = self._position
        if start + length > len(self._body):
            raise RecordDamageError(f"a record's field of {length} bytes is cut off")
        self._position = start + length
        return start

    def read(self, length: int) -> bytes:
        start = self._take(length)
        return self._body[start : start + length]

    def read1(self) -> int:
        return int(self._body[self._take(1)])

    def read2(self) -> int:
        return int(_U16.unpack_from(self._body, self._take(2))[0])

    def read4(self) -> int:
        return int(_U32.unpack_from(self._body, self._take(4))[0])

    def read8(self) -> int:
        return int(_U64.unpack_from(self._body, self._take(8))[0])

    def read_prefixed_string(self) -> str:
        return str(self.read(self.read4()), "utf-8")


def read_record(opcode: int, body: bytes) -> McapRecord:
    """The record of ``opcode`` whose body is exactly ``body``."""
    kind: Any = _RECORD_TYPES.get(opcode)
    if kind is None:
        raise RecordDamageError(f"unknown record opcode {opcode:#x}")
    stream = _Fields(body)
    record: McapRecord = kind.read(stream, len(body)) if kind is Message else kind.read(stream)
    if stream.count != len(body):
        raise RecordDamageError(f"a record has {len(body) - stream.count} extra bytes")
    return record


def unpack_chunk(chunk: Chunk) -> bytes:
    """The data of a chunk within its bounds (a compression the format allows, at most
    one chunk's size), decompressed and checked against its CRC, always: the writer
    always writes one, so a stored 0 is not "no CRC" but must match."""
    size = chunk.uncompressed_size
    if chunk.compression not in _COMPRESSIONS:
        raise RecordDamageError(f"unknown chunk compression {chunk.compression!r}")
    if size > MAX_CHUNK_BYTES:
        raise RecordDamageError(f"a chunk claims {size} bytes uncompressed")
    data = chunk.data
    if chunk.compression == "zstd":
        try:
            data = zstandard.ZstdDecompressor().stream_reader(data).read(size + 1)
        except zstandard.ZstdError as exc:
            raise RecordDamageError(f"chunk does not decompress: {exc}") from None
    if len(data) != size:
        raise RecordDamageError(f"chunk holds {len(data)} bytes where it declares {size}")
    if zlib.crc32(data) != chunk.uncompressed_crc:
        raise RecordDamageError("chunk CRC mismatch")
    return data


def split_records(data: bytes, allowed: frozenset[int], where: str) -> list[McapRecord]:
    """The records packed in ``data`` (an opened chunk, the summary section), each of a kind
    in ``allowed``."""
    records: list[McapRecord] = []
    position = 0
    while position < len(data):
        if position + RECORD_HEAD > len(data):
            raise RecordDamageError(f"a record inside {where} is cut off")
        opcode, length = struct.unpack_from("<BQ", data, position)
        start = position + RECORD_HEAD
        position = start + length
        if opcode not in allowed or position > len(data):
            raise RecordDamageError(f"a damaged record inside {where} (opcode {opcode:#x})")
        records.append(read_record(opcode, data[start:position]))
    return records
