"""Reading session logs: complete, cut off, zero-filled, damaged, foreign or from the future."""

from __future__ import annotations

import struct
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import pytest
from mcap.opcode import Opcode
from mcap.writer import Writer

from beatlog.errors import (
    CorruptLogError,
    LogError,
    NotABeatlogError,
    UnsupportedVersionError,
)
from beatlog.log.format import FORMAT_VERSION, CycleRecord, SessionEnd
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.log.writer import SessionLogWriter
from tests.columned import write_states
from tests.conftest import PERIOD_NS, Probe, RecordFn
from tests.crafting import (
    CYCLES,
    CYCLES_PER_CHUNK,
    Original,
    craft_log,
    cut_points,
    encoded,
    header_message,
    read_all,
    session_header,
    top_level_records,
    write,
)
from tests.factories import MAGIC_LENGTH, PROBE_CYCLE_DAMAGE, RECORD_HEAD, rewrite_cycle

CHUNK_DATA_START = RECORD_HEAD + 8 + 8 + 8 + 4 + 4 + len("zstd") + 8
"""Where a zstd chunk's compressed records start, from the start of its record."""


# A complete log


def test_a_complete_log_reads_every_cycle_and_says_complete(
    tmp_path: Path, original: Original
) -> None:
    log = write(tmp_path / "copy.beatlog", original.data)

    with SessionLogReader(log) as reader:
        batches = list(reader.batches())
        status, end = reader.status, reader.end

    assert [len(batch) for batch in batches] == [CYCLES_PER_CHUNK] * (CYCLES // CYCLES_PER_CHUNK)
    assert encoded([cycle for batch in batches for cycle in batch]) == original.cycles
    assert status == LogStatus(complete=True, cycles=CYCLES)
    assert status.describe() == "complete"
    assert end == SessionEnd(cycles=CYCLES, robot_time_ns=CYCLES * PERIOD_NS + sum(range(CYCLES)))


def test_the_status_is_unknown_until_the_cycles_have_been_read(
    tmp_path: Path, original: Original
) -> None:
    with SessionLogReader(write(tmp_path / "copy.beatlog", original.data)) as reader:
        with pytest.raises(RuntimeError, match="only after reading"):
            _ = reader.status
        assert reader.header.behaviors == ["near"]


# Files that are not session logs


def missing(tmp_path: Path) -> Path:
    return tmp_path / "missing.beatlog"


def directory(tmp_path: Path) -> Path:
    path = tmp_path / "logs.beatlog"
    path.mkdir()
    return path


def empty(tmp_path: Path) -> Path:
    return write(tmp_path / "empty.beatlog", b"")


def garbage(tmp_path: Path) -> Path:
    return write(tmp_path / "garbage.beatlog", b"GIF89a this is a picture, not a log\n" * 20)


@pytest.mark.parametrize(
    ("make", "problem"),
    [
        (missing, "no such file"),
        (directory, "is a directory, not a session log"),
        (empty, "empty file"),
        (garbage, "not a session log (not an MCAP file)"),
    ],
)
def test_a_file_that_is_not_a_session_log_is_named_in_the_error(
    tmp_path: Path, make: Callable[[Path], Path], problem: str
) -> None:
    path = make(tmp_path)

    with pytest.raises(NotABeatlogError) as raised:
        SessionLogReader(path)

    assert raised.value.path == path
    assert str(raised.value) == f"{path}: {problem}"


def write_foreign_mcap(path: Path, profile: str) -> Path:
    with path.open("wb") as file:
        writer = Writer(file)
        writer.start(profile=profile, library="rosbag2")
        schema = writer.register_schema("std_msgs/String", "ros2msg", b"string data")
        channel = writer.register_channel("/chatter", "cdr", schema)
        writer.add_message(channel, 1, b"\x00\x01\x00\x00hello", 1)
        writer.finish()  # type: ignore[no-untyped-call]
    return path


def test_an_mcap_file_from_another_tool_is_rejected_naming_its_profile(tmp_path: Path) -> None:
    path = write_foreign_mcap(tmp_path / "bag.mcap", "ros2")

    with pytest.raises(NotABeatlogError) as raised:
        SessionLogReader(path)

    assert (
        str(raised.value) == f"{path}: an MCAP file with profile 'ros2', not a beatlog session log"
    )


def test_a_log_from_a_newer_format_version_asks_for_an_upgrade(tmp_path: Path) -> None:
    path = tmp_path / "future.beatlog"
    SessionLogWriter(path, session_header(format_version=FORMAT_VERSION + 1)).close()

    with pytest.raises(UnsupportedVersionError) as raised:
        SessionLogReader(path)

    assert isinstance(raised.value, LogError)
    assert str(raised.value) == (
        f"{path}: written in format version {FORMAT_VERSION + 1}; this beatlog reads up to "
        f"{FORMAT_VERSION} (upgrade beatlog)"
    )


# Damage before the end


@pytest.mark.parametrize("where", ["first", "middle", "last"])
def test_damage_inside_an_early_chunk_is_an_error_not_a_wrong_result(
    tmp_path: Path, original: Original, where: str
) -> None:
    third = original.cycle_chunks[2]
    start, stop = third.offset + CHUNK_DATA_START, third.end - 1
    position = {"first": start, "middle": (start + stop) // 2, "last": stop}[where]
    damaged = bytearray(original.data)
    damaged[position] ^= 0xFF
    log = write(tmp_path / "damaged.beatlog", bytes(damaged))

    read: list[CycleRecord] = []
    with SessionLogReader(log) as reader, pytest.raises(CorruptLogError) as raised:
        read.extend(reader.cycles())

    assert str(raised.value).startswith(f"{log}: damaged record at byte {third.offset}")
    assert encoded(read) == original.cycles[: 2 * CYCLES_PER_CHUNK]


def with_record_head(data: bytes, at: int, opcode: int, length: int) -> bytes:
    return data[:at] + struct.pack("<BQ", opcode, length) + data[at + RECORD_HEAD :]


def claim_a_huge_record(original: Original) -> tuple[bytes, int]:
    at = original.header_end
    return with_record_head(original.data, at, Opcode.MESSAGE_INDEX, 2**62), at


def claim_a_huge_unknown_record(original: Original) -> tuple[bytes, int]:
    at = original.cycle_chunks[0].offset
    return with_record_head(original.data, at, 0x42, 2**62), at


def claim_a_huge_chunk_content(original: Original) -> tuple[bytes, int]:
    at = original.cycle_chunks[0].offset
    size_field = at + RECORD_HEAD + 16
    data = original.data
    return data[:size_field] + struct.pack("<Q", 2**62) + data[size_field + 8 :], at


@pytest.mark.parametrize(
    "hostile", [claim_a_huge_record, claim_a_huge_unknown_record, claim_a_huge_chunk_content]
)
def test_a_hostile_length_is_rejected_without_allocating_it(
    tmp_path: Path, original: Original, hostile: Callable[[Original], tuple[bytes, int]]
) -> None:
    data, at = hostile(original)
    log = write(tmp_path / "hostile.beatlog", data)

    tracemalloc.start()
    try:
        with SessionLogReader(log) as reader, pytest.raises(CorruptLogError) as raised:
            list(reader.cycles())
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()

    assert str(raised.value).startswith(f"{log}: damaged record at byte {at}")
    assert peak < 10 * 2**20


# Truncation: kill -9 and power loss


def cycles_flushed_before(original: Original, offset: int) -> int:
    """The cycles in the chunks that were completely on disk before ``offset``."""
    return CYCLES_PER_CHUNK * sum(1 for chunk in original.cycle_chunks if chunk.end <= offset)


def assert_truncated_prefix(original: Original, log: Path, cut: int) -> None:
    cycles, status = read_all(log)

    assert len(cycles) == cycles_flushed_before(original, cut) <= CYCLES
    assert encoded(cycles) == original.cycles[: len(cycles)]
    assert (status.complete, status.cycles) == (False, len(cycles))
    assert status.describe().startswith(f"truncated at cycle {len(cycles)}: ")


@pytest.mark.parametrize("sample", range(40))
def test_a_log_cut_anywhere_reads_up_to_its_last_flushed_batch(
    tmp_path: Path, original: Original, sample: int
) -> None:
    cut = cut_points(original.header_end + 1, original.footer.end - 1)[sample]
    log = write(tmp_path / "cut.beatlog", original.data[:cut])

    assert_truncated_prefix(original, log, cut)


def test_a_log_cut_right_after_its_header_is_truncated_at_cycle_zero(
    tmp_path: Path, original: Original
) -> None:
    log = write(tmp_path / "cut.beatlog", original.data[: original.header_end])

    cycles, status = read_all(log)

    assert cycles == []
    assert status == LogStatus(False, 0, "the recording stopped before the log was closed")
    assert status.describe().startswith("truncated at cycle 0: ")


@pytest.mark.parametrize("keep", [MAGIC_LENGTH, MAGIC_LENGTH + 20, "inside the header chunk"])
def test_a_log_cut_before_its_header_is_complete_cannot_be_read(
    tmp_path: Path, original: Original, keep: int | str
) -> None:
    cut = original.header_end - 1 if isinstance(keep, str) else keep
    log = write(tmp_path / "cut.beatlog", original.data[:cut])

    with pytest.raises(CorruptLogError) as raised:
        SessionLogReader(log)

    assert str(raised.value) == f"{log}: cut off before its session header"


@pytest.mark.parametrize("sample", range(40))
def test_a_log_with_a_zero_filled_tail_reads_as_truncated(
    tmp_path: Path, original: Original, sample: int
) -> None:
    """Power loss: the file has its full length, but its last blocks were never written."""
    zeros_from = cut_points(original.header_end, original.footer.offset)[sample]
    data = original.data
    log = write(tmp_path / "zeroed.beatlog", data[:zeros_from] + bytes(len(data) - zeros_from))

    assert_truncated_prefix(original, log, zeros_from)


def test_zeros_from_a_record_boundary_say_where_the_zeros_start(
    tmp_path: Path, original: Original
) -> None:
    boundary = original.cycle_chunks[5].offset
    data = original.data
    log = write(tmp_path / "zeroed.beatlog", data[:boundary] + bytes(len(data) - boundary))

    cycles, status = read_all(log)

    assert encoded(cycles) == original.cycles[: 5 * CYCLES_PER_CHUNK]
    assert status.describe() == (
        f"truncated at cycle {5 * CYCLES_PER_CHUNK}: zero-filled from byte {boundary} (power loss?)"
    )


# An index damaged after intact cycles

INDEX_DAMAGE = {
    "a chunk index's start time": "the summary does not match its CRC in the footer",
    "the footer's summary CRC": "the summary does not match its CRC in the footer",
    "the closing magic": "damaged or extra bytes after the log's footer",
}


def damage_index(original: Original, damage: str) -> bytes:
    """The original with one byte of its index flipped: no cycle and no end record touched."""
    [first_index, *_] = [
        r for r in top_level_records(original.data) if r.opcode == Opcode.CHUNK_INDEX
    ]
    byte = {
        "a chunk index's start time": first_index.offset + RECORD_HEAD,
        "the footer's summary CRC": original.footer.end - 1,
        "the closing magic": len(original.data) - 1,
    }[damage]
    data = bytearray(original.data)
    data[byte] ^= 0x01
    return bytes(data)


@pytest.mark.parametrize("damage", INDEX_DAMAGE)
def test_a_damaged_index_is_corrupt_though_every_cycle_reads_back(
    tmp_path: Path, original: Original, damage: str
) -> None:
    log = write(tmp_path / "index.beatlog", damage_index(original, damage))

    with pytest.raises(CorruptLogError) as raised:
        read_all(log)

    assert str(raised.value) == f"{log}: index damaged, data intact: {INDEX_DAMAGE[damage]}"


@pytest.mark.parametrize("damage", INDEX_DAMAGE)
def test_a_reader_tolerating_a_damaged_index_reads_every_cycle_and_says_so(
    tmp_path: Path, original: Original, damage: str
) -> None:
    log = write(tmp_path / "index.beatlog", damage_index(original, damage))

    with SessionLogReader(log, tolerate_damaged_index=True) as reader:
        cycles = list(reader.cycles())
        status = reader.status

    assert encoded(cycles) == original.cycles
    assert status == LogStatus(True, CYCLES, INDEX_DAMAGE[damage])
    assert status.describe() == f"index damaged, data intact: {INDEX_DAMAGE[damage]}"


def test_a_reader_tolerating_a_damaged_index_still_refuses_damaged_cycles(
    tmp_path: Path, original: Original
) -> None:
    data = bytearray(damage_index(original, "a chunk index's start time"))
    chunk = original.cycle_chunks[3]
    data[chunk.end - 1] ^= 0xFF
    log = write(tmp_path / "both.beatlog", bytes(data))

    with (
        SessionLogReader(log, tolerate_damaged_index=True) as reader,
        pytest.raises(CorruptLogError) as raised,
    ):
        list(reader.cycles())

    assert str(raised.value).startswith(f"{log}: damaged record at byte {chunk.offset}: ")


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("robot_id", "dog\x1b]0;owned\x07"),
        ("software_version", "1.0\x1b[2J"),
        ("system", "robot:system\n"),
        ("robot_state_type", "Probe\x9b31m"),
        ("behaviors", ["avoid", "wander\r"]),
        ("python_version", "3.12\x1b[2J"),
    ],
)
def test_a_header_name_with_control_characters_is_a_corrupt_log(
    tmp_path: Path, field: str, value: object
) -> None:
    log = craft_log(tmp_path / "escape.beatlog", [header_message(**{field: value})])

    with pytest.raises(CorruptLogError) as raised:
        SessionLogReader(log)

    shown = repr(value[1]) if isinstance(value, list) else repr(value)
    named = "behavior 1" if isinstance(value, list) else field
    assert str(raised.value) == (
        f"{log}: damaged session header: {named} {shown} holds control characters"
    )


# reading from a cycle on (a window's fresh start)


def test_batches_from_a_cycle_on_are_the_logs_cycles_from_there_checked_to_its_end(
    record_chunked: RecordFn,
) -> None:
    log = record_chunked(300)
    with SessionLogReader(log) as reader:
        every = [cycle for batch in reader.batches() for cycle in batch]

    with SessionLogReader(log) as reader:
        later = [cycle for batch in reader.batches(123) for cycle in batch]
        status, robot_time_ns = reader.status, reader.robot_time_ns

    assert later == every[123:]
    assert status == LogStatus(True, 300)
    assert robot_time_ns == sum(cycle.heartbeat_ns for cycle in every)


def test_batches_from_a_cycle_on_still_refuse_a_damaged_record_before_it(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    damage = PROBE_CYCLE_DAMAGE["record-extra-element"]
    log = rewrite_cycle(record_probe(60), tmp_path / "damaged.beatlog", damage.cycle, damage.edit)

    with SessionLogReader(log) as reader, pytest.raises(CorruptLogError) as raised:
        list(reader.batches(damage.cycle + 10))

    assert str(raised.value) == f"{log}: {damage.problem}"


def test_batches_from_a_cycle_on_leave_the_parts_of_the_cycles_before_it_undecoded(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    damage = PROBE_CYCLE_DAMAGE["robot-state-empty"]  # no robot state a replay could take
    log = rewrite_cycle(record_probe(60), tmp_path / "damaged.beatlog", damage.cycle, damage.edit)

    with SessionLogReader(log) as reader:
        reader.decode_states(Probe)
        later = [cycle for batch in reader.batches(damage.cycle + 1) for cycle in batch]

    assert len(later) == 60 - damage.cycle - 1


def test_batches_from_a_cycle_on_of_a_log_stored_by_field(tmp_path: Path) -> None:
    states = [Probe(distance=t / 10) for t in range(40)]
    log = write_states(tmp_path / "by-field.beatlog", states, by_field=True)
    with SessionLogReader(log) as reader:
        every = [cycle for batch in reader.batches() for cycle in batch]

    with SessionLogReader(log) as reader:
        later = [cycle for batch in reader.batches(13) for cycle in batch]

    assert later == every[13:]
