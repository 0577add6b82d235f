"""The cycle count of a closed log, read from its end record alone."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.opcode import Opcode

from beatlog.errors import CorruptLogError
from beatlog.log.index import recorded_cycles
from tests.crafting import (
    CYCLES,
    Original,
    chunks,
    cut_points,
    read_all,
    top_level_records,
    write,
    write_chunked_log,
)
from tests.factories import MAGIC_LENGTH, RECORD_HEAD


def test_the_cycle_count_of_a_closed_log_comes_from_its_end_record(
    tmp_path: Path, original: Original
) -> None:
    one_chunk = write_chunked_log(tmp_path / "short.beatlog", cycles=7)

    assert recorded_cycles(write(tmp_path / "chunked.beatlog", original.data)) == CYCLES
    assert recorded_cycles(one_chunk) == 7


def test_the_cycle_count_reads_only_the_end_of_the_log(tmp_path: Path, original: Original) -> None:
    """The cycle chunks are damaged: only the footer, summary and last chunk are read."""
    data = bytearray(original.data)
    for chunk in original.cycle_chunks:
        data[chunk.end - 1] ^= 0xFF
    damaged = write(tmp_path / "damaged.beatlog", bytes(data))

    assert recorded_cycles(damaged) == CYCLES
    with pytest.raises(CorruptLogError):
        read_all(damaged)


@pytest.mark.parametrize("sample", range(10))
def test_a_log_cut_anywhere_has_no_cycle_count(
    tmp_path: Path, original: Original, sample: int
) -> None:
    cut = cut_points(MAGIC_LENGTH, len(original.data) - 1, count=10)[sample]

    assert recorded_cycles(write(tmp_path / "cut.beatlog", original.data[:cut])) is None


@pytest.mark.parametrize(
    "damage",
    [
        "the end record's chunk",
        "the summary",
        "a chunk index's start time",
        "the footer",
        "the closing magic",
    ],
)
def test_a_damaged_end_has_no_cycle_count(tmp_path: Path, original: Original, damage: str) -> None:
    last_chunk = chunks(original.data)[-1]
    records = top_level_records(original.data)
    [data_end] = [r for r in records if r.opcode == Opcode.DATA_END]
    first_index = next(r for r in records if r.opcode == Opcode.CHUNK_INDEX)
    byte = {
        "the end record's chunk": last_chunk.end - 1,
        "the summary": data_end.end,  # the opcode of its first record
        "a chunk index's start time": first_index.offset + RECORD_HEAD,  # read by nothing else
        "the footer": original.footer.offset + RECORD_HEAD + 2,
        "the closing magic": len(original.data) - 1,
    }[damage]
    data = bytearray(original.data)
    data[byte] ^= 0xFF

    assert recorded_cycles(write(tmp_path / "damaged.beatlog", bytes(data))) is None


def test_what_is_no_closed_log_has_no_cycle_count(tmp_path: Path) -> None:
    empty = write(tmp_path / "empty.beatlog", b"")
    foreign = write(tmp_path / "notes.beatlog", b"not a log at all, only some words " * 10)

    assert recorded_cycles(empty) is None
    assert recorded_cycles(foreign) is None
    assert recorded_cycles(tmp_path / "missing.beatlog") is None
    assert recorded_cycles(tmp_path) is None
