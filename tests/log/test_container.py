"""A log's records, read field by field in place, are the records mcap's own reader reads."""

from __future__ import annotations

from io import BytesIO
from pathlib import Path

import pytest
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

from beatlog.log.container import RECORD_HEAD, RecordDamageError, read_record, unpack_chunk
from tests.crafting import top_level_records, write_chunked_log

KINDS: dict[int, type[McapRecord]] = {
    Opcode.HEADER: Header,
    Opcode.FOOTER: Footer,
    Opcode.SCHEMA: Schema,
    Opcode.CHANNEL: Channel,
    Opcode.MESSAGE: Message,
    Opcode.CHUNK: Chunk,
    Opcode.MESSAGE_INDEX: MessageIndex,
    Opcode.CHUNK_INDEX: ChunkIndex,
    Opcode.STATISTICS: Statistics,
    Opcode.SUMMARY_OFFSET: SummaryOffset,
    Opcode.DATA_END: DataEnd,
}


def mcaps_own(opcode: int, body: bytes) -> McapRecord:
    """The record as mcap reads it: its ``ReadDataStream`` over a copy of the body."""
    stream = ReadDataStream(BytesIO(body))
    kind = KINDS[opcode]
    return kind.read(stream, len(body)) if kind is Message else kind.read(stream)  # type: ignore[attr-defined,no-any-return]


def records_of(data: bytes) -> list[tuple[int, bytes]]:
    """Every record of a log with its body: the top-level ones, and those in its chunks."""
    found = []
    for record in top_level_records(data):
        body = data[record.offset + RECORD_HEAD : record.end]
        found.append((record.opcode, body))
        if record.opcode == Opcode.CHUNK:
            chunk = mcaps_own(record.opcode, body)
            assert isinstance(chunk, Chunk)
            found.extend(packed(unpack_chunk(chunk)))
    return found


def packed(data: bytes) -> list[tuple[int, bytes]]:
    """The records packed in an opened chunk, each with its body."""
    found, position = [], 0
    while position < len(data):
        start = position + RECORD_HEAD
        position = start + int.from_bytes(data[position + 1 : start], "little")
        found.append((data[start - RECORD_HEAD], data[start:position]))
    return found


def test_every_record_reads_as_mcaps_own_reader_reads_it(tmp_path: Path) -> None:
    data = write_chunked_log(tmp_path / "chunked.beatlog").read_bytes()
    records = records_of(data)

    assert {opcode for opcode, _ in records} == set(KINDS)
    for opcode, body in records:
        assert read_record(opcode, body) == mcaps_own(opcode, body)


@pytest.mark.parametrize("cut", [1, 7])
def test_a_field_cut_short_is_damage_where_mcap_would_read_less(tmp_path: Path, cut: int) -> None:
    data = write_chunked_log(tmp_path / "chunked.beatlog").read_bytes()
    opcode, body = next((o, b) for o, b in records_of(data) if o == Opcode.CHANNEL)

    with pytest.raises(RecordDamageError, match="cut off"):
        read_record(opcode, body[:-cut])
