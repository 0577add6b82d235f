"""What a closed log's index says, read cheaply: the cycles its end record counts."""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path
from typing import IO

import msgspec
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, ChunkIndex, Footer, Message

from beatlog.log.container import (
    CHUNK_RECORDS,
    FOOTER_RECORD,
    MAGIC,
    SUMMARY_RECORDS,
    RecordDamageError,
    split_records,
    unpack_chunk,
)
from beatlog.log.files import irregular_file_problem
from beatlog.log.format import DECODE_ERRORS, END_TOPIC, SessionEnd
from beatlog.log.limits import MAX_CHUNK_BYTES

__all__ = ["recorded_cycles"]


def recorded_cycles(path: str | Path) -> int | None:
    """The cycles the end record of a closed log counts, or None where there is none to
    read cheaply (the log was cut off, is damaged, or is no session log). Only the
    footer, the summary (checked against its CRC) and the chunk that holds the end
    record are read, each within the bounds of :mod:`beatlog.log.limits`: a cost that
    does not grow with the recording, for planning work such as sharding a suite."""
    path = Path(path)
    if irregular_file_problem(path) is not None:
        return None
    try:
        with path.open("rb") as file:
            return _end_record_cycles(file, os.fstat(file.fileno()).st_size)
    except (OSError, McapError, RecordDamageError, ValueError, struct.error, *DECODE_ERRORS):
        return None


def _end_record_cycles(file: IO[bytes], size: int) -> int | None:
    """The end record's cycle count, found through the footer and the summary's index."""
    footer_at = size - len(MAGIC) - FOOTER_RECORD
    if footer_at <= len(MAGIC) or file.read(len(MAGIC)) != MAGIC:
        return None
    file.seek(footer_at)
    tail = file.read(FOOTER_RECORD + len(MAGIC))
    if tail[FOOTER_RECORD:] != MAGIC:
        return None
    (footer,) = split_records(tail[:FOOTER_RECORD], frozenset({Opcode.FOOTER}), "the footer")
    assert isinstance(footer, Footer)
    summary_start = footer.summary_start
    if not len(MAGIC) < summary_start <= footer_at or footer_at - summary_start > MAX_CHUNK_BYTES:
        return None
    file.seek(summary_start)
    section = file.read(footer_at - summary_start)
    if zlib.crc32(tail[: FOOTER_RECORD - 4], zlib.crc32(section)) != footer.summary_crc:
        return None
    summary = split_records(section, SUMMARY_RECORDS, "the summary")
    ends = {r.id for r in summary if isinstance(r, Channel) and r.topic == END_TOPIC}
    # A chunk holds at most MAX_CHUNK_BYTES, and compression never doubles it.
    holding = [
        (r.chunk_start_offset, r.chunk_length)
        for r in summary
        if isinstance(r, ChunkIndex)
        and not ends.isdisjoint(r.message_index_offsets)
        and r.chunk_length <= 2 * MAX_CHUNK_BYTES
        and r.chunk_start_offset + r.chunk_length <= summary_start
    ]
    if len(ends) != 1 or len(holding) != 1:
        return None
    file.seek(holding[0][0])
    (chunk,) = split_records(file.read(holding[0][1]), frozenset({Opcode.CHUNK}), "a chunk")
    assert isinstance(chunk, Chunk)
    records = split_records(unpack_chunk(chunk), CHUNK_RECORDS, "a chunk")
    end = [r for r in records if isinstance(r, Message) and r.channel_id in ends]
    if len(end) != 1:
        return None
    return msgspec.msgpack.decode(end[0].data, type=SessionEnd).cycles
