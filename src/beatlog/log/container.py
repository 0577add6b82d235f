"""Byte-level reading of a session log's MCAP container: records, chunks, the summary.

All reading of the container's bytes happens here, with the ``mcap`` package's record
types and ``struct`` for the records read once a batch. The container knows nothing of
payload encodings (:mod:`beatlog.log.payload`) nor of what makes a log whole
(:mod:`beatlog.log.integrity`); a record not as the format defines it is a
:class:`RecordDamageError`.
"""

from __future__ import annotations

import struct
import threading
import zlib
from io import BytesIO
from typing import cast

import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
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
    "check_chunk_bounds",
    "read_chunk",
    "read_chunk_index",
    "read_record",
    "split_records",
    "summary_crc",
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


class RecordDamageError(Exception):
    """A record is not what the writer writes; corrupt unless it is the last.

    Internal to the log package: readers turn it into a
    :class:`~beatlog.errors.LogError` naming the file, or a truncation.
    """


def read_record(opcode: int, body: bytes) -> McapRecord:
    """A top-level record other than a chunk, a message index or the footer."""
    if opcode == Opcode.CHUNK_INDEX:
        return read_chunk_index(body)
    reader = _TOP_LEVEL.get(Opcode(opcode)) if opcode in KNOWN_OPCODES else None
    if reader is None:
        raise RecordDamageError(f"unknown record opcode {opcode:#x}")
    record: McapRecord = reader(ReadDataStream(BytesIO(body)))
    return record


def summary_crc(head: bytes, body: bytes, crc: int) -> int:
    """The summary CRC so far, given one more record after the data section: all of it,
    or of the footer the fields before the CRC itself (as MCAP defines it)."""
    crc = zlib.crc32(head, crc)
    if head[0] == Opcode.FOOTER:
        return zlib.crc32(body[: FOOTER_BYTES - 4], crc)
    return zlib.crc32(body, crc)


_CHUNK_HEAD = struct.Struct("<QQQII")
"""A chunk's fixed fields: start and end time, uncompressed size and CRC, the length
of its compression's name."""


def read_chunk(body: bytes) -> Chunk:
    """A chunk record's fields, read with ``struct`` (the hot path: one per batch)."""
    start, end, size, crc, name_length = _CHUNK_HEAD.unpack_from(body)
    at = _CHUNK_HEAD.size + name_length
    compression = str(body[_CHUNK_HEAD.size : at], "utf-8")
    (length,) = struct.unpack_from("<Q", body, at)
    # Not copied (a chunk is most of a log's bytes): a view, which every reader of a
    # chunk's data reads as it reads bytes.
    data = cast("bytes", memoryview(body)[at + 8 :])
    if len(data) != length:
        raise RecordDamageError(
            f"a chunk holds {len(data)} bytes of records where it declares {length}"
        )
    return Chunk(
        compression=compression,
        data=data,
        message_end_time=end,
        message_start_time=start,
        uncompressed_crc=crc,
        uncompressed_size=size,
    )


_INDEX_HEAD = struct.Struct("<QQQQI")
"""A chunk index's first fields: start and end time, the chunk's offset and length, the
length of its message index offsets."""
_INDEX_OFFSET = struct.Struct("<HQ")
_INDEX_TAIL = struct.Struct("<QI")
_INDEX_SIZES = struct.Struct("<QQ")


def read_chunk_index(body: bytes) -> ChunkIndex:
    """A chunk index record's fields, read with ``struct`` (the summary holds one a chunk)."""
    start, end, chunk_at, chunk_length, offsets_length = _INDEX_HEAD.unpack_from(body)
    at = _INDEX_HEAD.size
    if offsets_length % _INDEX_OFFSET.size:
        raise RecordDamageError("a chunk index with a damaged message index offset")
    offsets = dict(_INDEX_OFFSET.iter_unpack(body[at : at + offsets_length]))
    at += offsets_length
    index_length, name_length = _INDEX_TAIL.unpack_from(body, at)
    at += _INDEX_TAIL.size
    compression = str(body[at : at + name_length], "utf-8")
    at += name_length
    compressed, uncompressed = _INDEX_SIZES.unpack_from(body, at)
    if at + _INDEX_SIZES.size != len(body):
        raise RecordDamageError(
            f"a chunk index has {len(body) - at - _INDEX_SIZES.size} extra bytes"
        )
    return ChunkIndex(
        message_index_offsets=offsets,
        chunk_start_offset=chunk_at,
        chunk_length=chunk_length,
        compression=compression,
        compressed_size=compressed,
        message_end_time=end,
        message_index_length=index_length,
        message_start_time=start,
        uncompressed_size=uncompressed,
    )


def check_chunk_bounds(chunk: Chunk) -> None:
    """A chunk must use a compression the format allows and stay within one chunk's size."""
    if chunk.compression not in _COMPRESSIONS:
        raise RecordDamageError(f"unknown chunk compression {chunk.compression!r}")
    if chunk.uncompressed_size > MAX_CHUNK_BYTES:
        raise RecordDamageError(f"a chunk claims {chunk.uncompressed_size} bytes uncompressed")


_THREAD = threading.local()


def _decompressor() -> zstandard.ZstdDecompressor:
    """This thread's zstd decompressor (one may not serve two threads at once)."""
    found: zstandard.ZstdDecompressor | None = getattr(_THREAD, "decompressor", None)
    if found is None:
        found = _THREAD.decompressor = zstandard.ZstdDecompressor()
    return found


def unpack_chunk(chunk: Chunk) -> bytes:
    """The data of a chunk within its bounds, decompressed and checked against its CRC.

    The CRC is always checked: beatlog's writer always computes it, so a stored 0
    is not "no CRC" but must match, like any other value.
    """
    size = chunk.uncompressed_size
    data = chunk.data
    if chunk.compression == "zstd":
        try:
            data = _decompressor().stream_reader(data).read(size + 1)
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
    view = cast("bytes", memoryview(data))  # a message's payload is a view, not a copy
    while position < len(data):
        if position + RECORD_HEAD > len(data):
            raise RecordDamageError(f"a record inside {where} is cut off")
        opcode, length = struct.unpack_from("<BQ", data, position)
        start = position + RECORD_HEAD
        position = start + length
        if opcode not in allowed or position > len(data):
            raise RecordDamageError(f"a damaged record inside {where} (opcode {opcode:#x})")
        if opcode == Opcode.MESSAGE:  # the common case, read without a stream
            if length < _MESSAGE_HEAD.size:
                raise RecordDamageError(f"a message inside {where} is cut off")
            channel, sequence, log_time, publish_time = _MESSAGE_HEAD.unpack_from(data, start)
            body = view[start + _MESSAGE_HEAD.size : position]
            records.append(Message(channel, log_time, body, publish_time, sequence))
            continue
        if opcode == Opcode.CHUNK_INDEX:  # one a chunk
            records.append(read_chunk_index(data[start:position]))
            continue
        stream = ReadDataStream(BytesIO(data[start:position]))
        records.append(_TOP_LEVEL[Opcode(opcode)](stream))
        if stream.count != length:
            raise RecordDamageError(
                f"a record inside {where} has {length - stream.count} extra bytes"
            )
    return records


_MESSAGE_HEAD = struct.Struct("<HIQQ")
"""A message record's fixed fields: channel id, sequence, log time, publish time."""


_TOP_LEVEL = {
    Opcode.HEADER: Header.read,
    Opcode.MESSAGE_INDEX: MessageIndex.read,
    Opcode.DATA_END: DataEnd.read,
    Opcode.SCHEMA: Schema.read,
    Opcode.CHANNEL: Channel.read,
    Opcode.STATISTICS: Statistics.read,
    Opcode.SUMMARY_OFFSET: SummaryOffset.read,
}
