"""A damaged, reordered, foreign or hostile log is an error naming the file, never a PASS."""

from __future__ import annotations

import os
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import msgspec
import pytest
import zstandard

from beatlog.errors import CorruptLogError, LogError, NotABeatlogError
from beatlog.log.format import CYCLES_TOPIC, FORMAT_VERSION, SessionHeader
from beatlog.log.limits import MAX_BEHAVIORS, MAX_CHUNK_BYTES, MAX_NAME_LENGTH
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.replay.judge import replay
from beatlog_examples.dog import SUITE_DIR
from tests.conftest import RecordFn, probe_system
from tests.crafting import (
    FORMAT_1_CHANNELS,
    STANDARD_CHANNELS,
    Channel,
    Message,
    chunks,
    craft_log,
    cycle_messages,
    deeply_nested,
    drop_chunk,
    end_message,
    header_message,
    repeat_chunk,
    replace_chunk_content,
    standard_messages,
    swap_chunks,
)
from tests.marks import one_by_default

DOG_SUITE = SUITE_DIR
COMMITTED_LOGS = sorted(DOG_SUITE.glob("*.beatlog"))


def read_through(path: Path) -> tuple[int, LogStatus]:
    """Read every cycle; the count and the status."""
    with SessionLogReader(path) as reader:
        count = sum(len(batch) for batch in reader.batches())
        return count, reader.status


def assert_refused(path: Path, problem: str) -> str:
    """Reading ``path`` must raise a LogError of one line: the path, then ``problem``;
    returns the message."""
    with pytest.raises(LogError) as raised:
        read_through(path)
    message = str(raised.value)
    assert message == f"{path}: {problem}"
    return message


def test_a_crafted_log_like_the_writers_reads_complete(tmp_path: Path) -> None:
    """The factories build exactly what the writer writes, so every refusal below is
    caused by the one thing each test changes."""
    log = craft_log(tmp_path / "good.beatlog", standard_messages(30))
    assert read_through(log) == (30, LogStatus(True, 30))


def test_a_format_1_log_reads_complete(tmp_path: Path) -> None:
    messages = standard_messages(30, version=1)
    log = craft_log(tmp_path / "v1.beatlog", messages, channels=FORMAT_1_CHANNELS)
    assert read_through(log) == (30, LogStatus(True, 30))


# Chunks missing, repeated or moved


Mutation = Callable[[bytes, int], bytes]
MUTATIONS: dict[str, Mutation] = {
    "dropped": lambda data, i: drop_chunk(data, chunks(data)[i]),
    "repeated": lambda data, i: repeat_chunk(data, chunks(data)[i]),
    "moved": lambda data, i: swap_chunks(data, chunks(data)[i - 1], chunks(data)[i]),
}


def every_mutation(data: bytes) -> list[tuple[str, int]]:
    """Each mutation at each chunk: drop or repeat any chunk, move any but the first."""
    count = len(chunks(data))
    return [
        (name, index) for name in MUTATIONS for index in range(1 if name == "moved" else 0, count)
    ]


@pytest.mark.parametrize("version", [1, 2])
def test_any_chunk_dropped_repeated_or_moved_is_refused(tmp_path: Path, version: int) -> None:
    channels = STANDARD_CHANNELS if version == 2 else FORMAT_1_CHANNELS
    log = craft_log(
        tmp_path / "log.beatlog", standard_messages(60, version=version), channels=channels
    )
    data = log.read_bytes()
    damaged = tmp_path / "damaged.beatlog"
    for name, index in every_mutation(data):
        damaged.write_bytes(MUTATIONS[name](data, index))
        with pytest.raises(LogError):
            read_through(damaged)


def test_a_chunk_missing_in_a_log_cut_off_mid_session_is_refused(tmp_path: Path) -> None:
    """Without the summary at the end, the cycle numbers of the batches catch it."""
    messages = [header_message(), *cycle_messages(60)]
    log = craft_log(tmp_path / "cut.beatlog", messages, finish=False)
    data = log.read_bytes()
    assert read_through(log) == (
        60,
        LogStatus(False, 60, "the recording stopped before the log was closed"),
    )
    log.write_bytes(drop_chunk(data, chunks(data)[3]))
    assert_refused(
        log,
        "cycles out of order: a batch starts at cycle 30 where cycle 20 is next "
        "(a chunk missing, repeated or moved)",
    )


def test_a_format_1_log_cut_off_mid_session_is_checked_by_robot_time(tmp_path: Path) -> None:
    messages = [header_message(format_version=1), *cycle_messages(60, version=1)]
    log = craft_log(tmp_path / "cut.beatlog", messages, channels=FORMAT_1_CHANNELS, finish=False)
    data = log.read_bytes()
    log.write_bytes(repeat_chunk(data, chunks(data)[3]))
    assert_refused(
        log,
        "cycles out of order: the batch after cycle 30 is stamped 630000000 ns of robot time, "
        "not 930000000 (a chunk missing, repeated or moved)",
    )


@pytest.mark.parametrize(
    "log",
    one_by_default(COMMITTED_LOGS, DOG_SUITE / "remote-into-wall.beatlog", lambda log: log.stem),
)
def test_no_chunk_of_a_committed_log_can_be_dropped_repeated_or_moved(
    tmp_path: Path, log: Path
) -> None:
    data = log.read_bytes()
    damaged = tmp_path / log.name
    for name, index in every_mutation(data):
        damaged.write_bytes(MUTATIONS[name](data, index))
        with pytest.raises(LogError):
            read_through(damaged)


def test_a_flipped_opcode_no_longer_hides_a_chunk(tmp_path: Path) -> None:
    """A chunk whose opcode byte became a user opcode (>= 0x80) was skipped before."""
    log = craft_log(tmp_path / "log.beatlog", standard_messages(60))
    data = bytearray(log.read_bytes())
    offset = chunks(bytes(data))[3].offset
    data[offset] = 0x80
    log.write_bytes(bytes(data))
    assert_refused(log, f"damaged record at byte {offset}: unexpected record (opcode 0x80)")


# Channels, schemas, encodings and order


@pytest.mark.parametrize(
    ("channels", "problem"),
    [
        (
            (*STANDARD_CHANNELS, Channel("/beatlog/cycles2", schema="beatlog.CycleBatch")),
            "a foreign channel '/beatlog/cycles2' in a session log",
        ),
        (
            (*STANDARD_CHANNELS, Channel("/other")),
            "foreign schema '' (jsonschema) in a session log",
        ),
        (
            (
                STANDARD_CHANNELS[0],
                Channel(CYCLES_TOPIC, encoding="json", schema="beatlog.CycleBatch"),
                STANDARD_CHANNELS[2],
            ),
            "channel '/beatlog/cycles' has encoding 'json', not 'msgpack'",
        ),
        (
            (
                STANDARD_CHANNELS[0],
                Channel(CYCLES_TOPIC, schema="beatlog.SessionEnd"),
                STANDARD_CHANNELS[2],
            ),
            "channel '/beatlog/cycles' has no schema the format defines for it",
        ),
        (
            (STANDARD_CHANNELS[0], FORMAT_1_CHANNELS[1], STANDARD_CHANNELS[2]),
            "cycles have schema 'beatlog.CycleRecord', "
            f"not the 'beatlog.ColumnBatch' of format version {FORMAT_VERSION}",
        ),
    ],
    ids=[
        "foreign-cycles-topic",
        "foreign-channel",
        "json-cycles",
        "wrong-schema",
        "format-1-schema",
    ],
)
def test_channels_the_format_does_not_define_are_refused(
    tmp_path: Path, channels: tuple[Channel, ...], problem: str
) -> None:
    log = craft_log(tmp_path / "log.beatlog", standard_messages(20), channels=channels)
    assert_refused(log, problem)


def test_a_second_header_channel_is_refused(tmp_path: Path) -> None:
    channels = (*STANDARD_CHANNELS, STANDARD_CHANNELS[0])
    log = craft_log(tmp_path / "log.beatlog", standard_messages(20), channels=channels)
    assert_refused(log, "a second channel '/beatlog/header' in a session log")


@pytest.mark.parametrize(
    ("messages", "problem"),
    [
        (
            [*standard_messages(20)[:-1], end_message(999)],
            "the end record counts 999 cycles and 29970000000 ns of robot time, "
            "but the log holds 20 cycles and 600000000 ns",
        ),
        (
            [*standard_messages(20)[:-1], end_message(20, robot_time_ns=1)],
            "the end record counts 20 cycles and 1 ns of robot time, "
            "but the log holds 20 cycles and 600000000 ns",
        ),
        (
            [*standard_messages(20)[:-1], end_message(-5, robot_time_ns=0)],
            "damaged end record: Expected `int` >= 0 - at `$.cycles`",
        ),
        (
            [*standard_messages(20), *cycle_messages(10, start=20)],
            "a message after the end record",
        ),
        (
            [*standard_messages(20)[:-1], header_message(), end_message(20)],
            "a second session header",
        ),
        (
            [header_message(), *cycle_messages(20)[1:], end_message(20)],
            "cycles out of order: a batch starts at cycle 10 where cycle 0 is next "
            "(a chunk missing, repeated or moved)",
        ),
        (
            [cycle_messages(20)[0], header_message(), end_message(10)],
            "first message is on '/beatlog/cycles', not the header",
        ),
    ],
    ids=[
        "end-999",
        "end-robot-time",
        "end-negative",
        "after-end",
        "second-header",
        "gap",
        "header-not-first",
    ],
)
def test_messages_out_of_place_or_disagreeing_with_the_end_record_are_refused(
    tmp_path: Path, messages: list[Message], problem: str
) -> None:
    log = tmp_path / "log.beatlog"
    craft_log(log, messages)
    assert_refused(log, problem)


def test_an_empty_batch_is_refused(tmp_path: Path) -> None:
    empty = Message(CYCLES_TOPIC, 0, msgspec.msgpack.encode([0, []]))
    log = craft_log(tmp_path / "log.beatlog", [header_message(), empty, end_message(0)])
    assert_refused(log, "the batch after cycle 0 is empty")


# The header's fields


HEADER_FIELDS = list(SessionHeader.__struct_fields__)


@pytest.mark.parametrize("field", HEADER_FIELDS)
def test_msgpack_nested_deep_in_any_header_field_is_a_corrupt_log(
    tmp_path: Path, field: str
) -> None:
    messages = standard_messages(5)
    messages[0] = header_message(**{field: deeply_nested()})
    log = craft_log(tmp_path / "deep.beatlog", messages)
    with pytest.raises(CorruptLogError):
        read_through(log)


@pytest.mark.parametrize(
    ("changes", "problem"),
    [
        ({"format_version": 0}, "Expected `int` >= 1 - at `$.format_version`"),
        ({"period_ns": 0}, "Expected `int` >= 1 - at `$.period_ns`"),
        ({"period_ns": -30}, "Expected `int` >= 1 - at `$.period_ns`"),
        ({"behaviors": ["walk", "walk"]}, "a behavior is named twice"),
        (
            {"behaviors": ["walk", "sit"], "initial_states": ["idle"]},
            "1 initial states for 2 behaviors",
        ),
        (
            {"robot_id": "r" * 10_000},
            f"Expected `str` of length <= {MAX_NAME_LENGTH} - at `$.robot_id`",
        ),
        (
            {"behaviors": [f"b{i}" for i in range(MAX_BEHAVIORS + 1)]},
            f"Expected `array` of length <= {MAX_BEHAVIORS} - at `$.behaviors`",
        ),
        (
            {"behaviors": ["b" * 1000]},
            f"Expected `str` of length <= {MAX_NAME_LENGTH} - at `$.behaviors[0]`",
        ),
        ({"start_time_ns": -1}, "Expected `int` >= 0 - at `$.start_time_ns`"),
        (
            {"setup_draws": [[0, "uniform", 2.5, [2.0, 3.0]]]},
            "set-up draw 1 is behavior #0's, not the system's",
        ),
        (
            {"format_version": 3, "setup_draws": [[-1, "uniform", 2.5, [2.0, 3.0]]]},
            "set-up draws in a log of format 3",
        ),
        (
            {"format_version": 4, "python_version": "3.12.1"},
            "a Python version in a log of format 4",
        ),
        (
            {"python_version": "3" * 1000},
            f"Expected `str` of length <= {MAX_NAME_LENGTH} - at `$.python_version`",
        ),
    ],
    ids=[
        "version-0",
        "period-0",
        "period-negative",
        "duplicate-behavior",
        "initial-states-short",
        "long-robot-id",
        "too-many-behaviors",
        "long-behavior-name",
        "negative-start",
        "set-up-draw-of-a-behavior",
        "set-up-draws-in-format-3",
        "python-version-in-format-4",
        "long-python-version",
    ],
)
def test_header_fields_out_of_bounds_are_refused(
    tmp_path: Path, changes: dict[str, object], problem: str
) -> None:
    messages = standard_messages(5)
    messages[0] = header_message(**changes)
    log = craft_log(tmp_path / "bad.beatlog", messages)
    with pytest.raises(CorruptLogError) as raised:
        read_through(log)
    assert str(raised.value) == f"{log}: damaged session header: {problem}"


def peak_memory_of_a_refusal(log: Path) -> int:
    """Read ``log``, which must be refused as corrupt; the peak memory it took (bytes)."""
    tracemalloc.start()
    try:
        with pytest.raises(CorruptLogError):
            read_through(log)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return peak


def test_a_huge_robot_id_in_a_small_file_is_refused_in_little_memory(tmp_path: Path) -> None:
    messages = standard_messages(5)
    messages[0] = header_message(robot_id="x" * 50_000_000)
    log = craft_log(tmp_path / "huge.beatlog", messages)
    assert log.stat().st_size < 100_000
    assert peak_memory_of_a_refusal(log) < 50 * 2**20


# Decompression bombs


@pytest.mark.parametrize(
    "declared",
    [2**40, MAX_CHUNK_BYTES + 1, None],
    ids=["claims-1-TiB", "claims-over-the-cap", "claims-little"],
)
def test_a_decompression_bomb_is_refused_without_inflating_it(
    tmp_path: Path, declared: int | None
) -> None:
    log = craft_log(tmp_path / "log.beatlog", standard_messages(30))
    bomb = zstandard.compress(b"\0" * (1 << 28))
    assert len(bomb) < 100_000
    data = log.read_bytes()
    log.write_bytes(replace_chunk_content(data, chunks(data)[1], bomb, declared=declared))
    assert peak_memory_of_a_refusal(log) < 40 * 2**20


# Special files


def test_a_fifo_is_refused_before_it_is_opened(tmp_path: Path) -> None:
    fifo = tmp_path / "session.beatlog"
    os.mkfifo(fifo)
    with pytest.raises(NotABeatlogError, match="not a regular file"):
        SessionLogReader(fifo)


def test_a_device_is_refused(tmp_path: Path) -> None:
    with pytest.raises(NotABeatlogError, match="not a regular file"):
        SessionLogReader("/dev/zero")


# A real recording


def test_a_recorded_log_with_a_chunk_dropped_never_replays(
    record_probe: RecordFn, tmp_path: Path
) -> None:
    log = record_probe(400, flush_interval_s=0.5)
    data = log.read_bytes()
    recorded = chunks(data)
    assert len(recorded) > 20
    damaged = tmp_path / "damaged.beatlog"
    for chunk in recorded:
        damaged.write_bytes(drop_chunk(data, chunk))
        with pytest.raises(LogError):
            replay(damaged, probe_system(), allow_truncated=True)


FORMAT_1_LOG = Path(__file__).parent.parent / "conformance" / "cases" / "format-1.beatlog"


def test_a_committed_format_1_log_still_reads_complete_with_its_version() -> None:
    log = FORMAT_1_LOG
    with SessionLogReader(log) as reader:
        cycles = sum(len(batch) for batch in reader.batches())
        assert reader.format_version == 1
        assert reader.status == LogStatus(True, cycles)
        assert reader.end is not None
        assert reader.robot_time_ns == reader.end.robot_time_ns


def test_a_header_not_stamped_at_time_zero_is_refused(tmp_path: Path) -> None:
    messages = standard_messages(5)
    messages[0] = messages[0]._replace(log_time=7)
    log = craft_log(tmp_path / "log.beatlog", messages)
    with pytest.raises(CorruptLogError, match="not stamped at time 0"):
        read_through(log)


def test_an_end_record_stamped_at_another_time_is_refused(tmp_path: Path) -> None:
    messages = standard_messages(5)
    messages[-1] = messages[-1]._replace(log_time=1)
    log = craft_log(tmp_path / "log.beatlog", messages)
    assert_refused(log, "the end record is not stamped with the session's robot time")


def test_a_log_without_its_end_channel_is_refused(tmp_path: Path) -> None:
    log = craft_log(
        tmp_path / "log.beatlog", standard_messages(5)[:-1], channels=STANDARD_CHANNELS[:2]
    )
    with pytest.raises(CorruptLogError, match="no /beatlog/end channel"):
        read_through(log)
