"""Session logs built by hand, message by message and chunk by chunk: valid ones, and
hostile variants of them (a chunk dropped, repeated, swapped or replaced, a value
nested too deep), for testing whatever reads session logs.

:func:`craft_log` writes an MCAP file shaped like a session log with whatever channels
and messages it is given; the ``*_message`` functions build the messages beatlog's
writer would write; :func:`top_level_records` and the chunk functions cut the file's
bytes. :func:`write_chunked_log` writes a log in many small chunks for the log tests
to cut and damage, and :func:`read_all` reads one back. Nothing here checks what it
builds: that is the reader's job.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import msgspec
from mcap.opcode import Opcode
from mcap.writer import CompressionType, Writer

from beatlog.log.container import MAGIC, RECORD_HEAD
from beatlog.log.format import (
    CYCLES_TOPIC,
    END_TOPIC,
    FORMAT_VERSION,
    HEADER_TOPIC,
    MESSAGE_ENCODING,
    PROFILE,
    SCHEMA_ENCODING,
    CycleRecord,
    SessionEnd,
    SessionHeader,
    cycles_record,
    schema_name,
)
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.log.recording import LogSource
from beatlog.log.writer import SessionLogWriter
from tests.conftest import PERIOD_NS, Probe

__all__ = [
    "CYCLES",
    "FORMAT_1_CHANNELS",
    "FORMAT_2_CHANNELS",
    "PERIOD_NS",
    "STANDARD_CHANNELS",
    "Channel",
    "Gauge",
    "Message",
    "Original",
    "Record",
    "channels",
    "chunks",
    "craft_log",
    "cut_points",
    "cycle",
    "cycle_messages",
    "deeply_nested",
    "drop_chunk",
    "encoded",
    "end_message",
    "header_message",
    "read_all",
    "repeat_chunk",
    "replace_chunk_content",
    "session_header",
    "standard_messages",
    "swap_chunks",
    "top_level_records",
    "write",
    "write_chunked_log",
]


class Gauge(msgspec.Struct, kw_only=True):
    """The robot state of crafted logs: each cycle's state is ``{"level": 1.0}``."""

    level: float = 0.0


def session_header(**changes: Any) -> SessionHeader:
    """A valid header of the current format; ``changes`` replace any of its fields."""
    fields: dict[str, Any] = {
        "format_version": FORMAT_VERSION,
        "beatlog_version": "test",
        "robot_id": "bench",
        "software_version": "test",
        "system": "",
        "period_ns": PERIOD_NS,
        "start_time_ns": 0,
        "robot_state_type": "tests.crafting.Gauge",
        "robot_state_schema": {},
        "behaviors": [],
    }
    fields.update(changes)
    return SessionHeader(**fields)


class Channel(NamedTuple):
    """A channel to register in a crafted log: topic, message encoding and schema name."""

    topic: str
    encoding: str = MESSAGE_ENCODING
    schema: str = ""


def channels(version: int = FORMAT_VERSION) -> tuple[Channel, ...]:
    """The three channels of a session log of format ``version``."""
    return (
        Channel(HEADER_TOPIC, schema=schema_name(SessionHeader)),
        Channel(CYCLES_TOPIC, schema=schema_name(cycles_record(version))),
        Channel(END_TOPIC, schema=schema_name(SessionEnd)),
    )


STANDARD_CHANNELS = channels()
FORMAT_2_CHANNELS = channels(2)
FORMAT_1_CHANNELS = channels(1)


class Message(NamedTuple):
    """A message to write: its topic, log time and payload bytes."""

    topic: str
    log_time: int
    data: bytes


def header_message(**changes: Any) -> Message:
    """The session header message; ``changes`` replace fields (values may be msgspec.Raw)."""
    fields = msgspec.structs.asdict(session_header())
    fields.update(changes)
    written = {key: value for key, value in fields.items() if value is not msgspec.UNSET}
    return Message(HEADER_TOPIC, 0, msgspec.msgpack.encode(written))


def cycle(heartbeat_ns: int = PERIOD_NS, state: Any = None, **parts: Any) -> list[Any]:
    """One cycle record as written: heartbeat, robot state, changes, draws, outputs, samples."""
    return [
        heartbeat_ns,
        {"level": 1.0} if state is None else state,
        parts.get("state_changes", []),
        parts.get("random_numbers", []),
        parts.get("outputs", {}),
        parts.get("samples", []),
    ]


def cycle_messages(
    count: int, *, per_batch: int = 10, version: int = FORMAT_VERSION, start: int = 0
) -> list[Message]:
    """``count`` cycles of one period each in batches, stamped as the writer stamps them."""
    messages = []
    for first in range(start, start + count, per_batch):
        cycles = [cycle() for _ in range(min(per_batch, start + count - first))]
        payload: Any = [first, cycles] if version >= 2 else cycles
        messages.append(
            Message(CYCLES_TOPIC, (first + 1) * PERIOD_NS, msgspec.msgpack.encode(payload))
        )
    return messages


def end_message(cycles: int, robot_time_ns: int | None = None, **changes: Any) -> Message:
    """The end record; its robot time defaults to ``cycles`` periods."""
    robot_time = cycles * PERIOD_NS if robot_time_ns is None else robot_time_ns
    fields = {"cycles": cycles, "robot_time_ns": robot_time, "overruns": 0, "error": None}
    fields.update(changes)
    return Message(END_TOPIC, robot_time, msgspec.msgpack.encode(fields))


def standard_messages(cycles: int = 30, *, version: int = FORMAT_VERSION) -> list[Message]:
    """Header, ``cycles`` cycles and the end record: a complete log's messages."""
    header = header_message(format_version=version)
    return [header, *cycle_messages(cycles, version=version), end_message(cycles)]


def craft_log(
    path: Path,
    messages: Sequence[Message],
    *,
    channels: Sequence[Channel] = STANDARD_CHANNELS,
    profile: str = PROFILE,
    chunk_size: int = 1,
    finish: bool = True,
) -> Path:
    """Write an MCAP file shaped like a session log, with whatever channels and messages.

    With ``chunk_size=1`` every message gets a chunk of its own, so chunks can be
    dropped, repeated or moved one by one.
    """
    with path.open("wb") as file:
        writer = Writer(file, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        writer.start(profile=profile, library="tests.crafting")
        ids: dict[str, int] = {}
        for channel in channels:
            schema = writer.register_schema(channel.schema, SCHEMA_ENCODING, b"{}")
            channel_id = writer.register_channel(channel.topic, channel.encoding, schema)
            ids.setdefault(channel.topic, channel_id)
        for message in messages:
            writer.add_message(ids[message.topic], message.log_time, message.data, message.log_time)
        if finish:
            writer.finish()  # type: ignore[no-untyped-call]
    return path


class Record(NamedTuple):
    """A top-level MCAP record: where it starts, its opcode and its body length."""

    offset: int
    opcode: int
    length: int

    @property
    def end(self) -> int:
        return self.offset + RECORD_HEAD + self.length


def top_level_records(data: bytes) -> list[Record]:
    """Every top-level record of an MCAP file's bytes, in order."""
    records = []
    offset = len(MAGIC)
    while offset < len(data) - len(MAGIC):
        opcode, length = struct.unpack_from("<BQ", data, offset)
        records.append(Record(offset, opcode, length))
        offset = records[-1].end
    return records


def chunks(data: bytes) -> list[Record]:
    """The chunk records of an MCAP file's bytes."""
    return [r for r in top_level_records(data) if r.opcode == Opcode.CHUNK]


def drop_chunk(data: bytes, chunk: Record) -> bytes:
    """The file without one chunk."""
    return data[: chunk.offset] + data[chunk.end :]


def repeat_chunk(data: bytes, chunk: Record) -> bytes:
    """The file with one chunk written twice in a row."""
    return data[: chunk.end] + data[chunk.offset : chunk.end] + data[chunk.end :]


def swap_chunks(data: bytes, first: Record, second: Record) -> bytes:
    """The file with two chunks exchanged (``first`` before ``second``)."""
    return (
        data[: first.offset]
        + data[second.offset : second.end]
        + data[first.end : second.offset]
        + data[first.offset : first.end]
        + data[second.end :]
    )


def replace_chunk_content(
    data: bytes, chunk: Record, compressed: bytes, *, declared: int | None = None
) -> bytes:
    """The file with one chunk's compressed records replaced, and its declared
    uncompressed size replaced too when ``declared`` is given."""
    body = chunk.offset + RECORD_HEAD
    start_end_size_crc = struct.Struct("<QQQI")
    start, end, size, crc = start_end_size_crc.unpack_from(data, body)
    compression_end = (
        body + start_end_size_crc.size + 4 + int.from_bytes(data[body + 28 : body + 32], "little")
    )
    new_body = (
        start_end_size_crc.pack(start, end, size if declared is None else declared, crc)
        + data[body + start_end_size_crc.size : compression_end]
        + len(compressed).to_bytes(8, "little")
        + compressed
    )
    head = struct.pack("<BQ", Opcode.CHUNK, len(new_body))
    return data[: chunk.offset] + head + new_body + data[chunk.end :]


def deeply_nested(depth: int = 100_000) -> msgspec.Raw:
    """A msgpack value nested ``depth`` arrays deep."""
    return msgspec.Raw(b"\x91" * depth + b"\xc0")


# a log in many small chunks for the log tests to cut and damage, and reading logs back

CYCLES = 200
CYCLES_PER_CHUNK = 10


def write_chunked_log(path: Path, cycles: int = CYCLES) -> Path:
    """A complete log in many small chunks: the header, one chunk per 10 cycles, the end."""
    writer = SessionLogWriter(
        path,
        session_header(behaviors=["near"]),
        batch_cycles=CYCLES_PER_CHUNK,
        chunk_size=1,
        flush_interval_s=60.0,
    )
    for t in range(cycles):
        changes = [(0, "far", "near")] if t % 7 == 0 else []
        draws = [(0, "random", t / cycles)] if t % 3 == 0 else []
        state = Probe(distance=1.0 - t / cycles, reading=float(t))
        writer.append(PERIOD_NS + t, state, changes, draws, {"t": t})
    writer.close(SessionEnd(cycles=cycles, robot_time_ns=cycles * PERIOD_NS + sum(range(cycles))))
    return path


class Original(NamedTuple):
    data: bytes
    cycles: list[bytes]
    """Each cycle encoded, to compare byte for byte."""
    header_end: int
    cycle_chunks: list[Record]
    footer: Record


def read_all(path: LogSource) -> tuple[list[CycleRecord], LogStatus]:
    with SessionLogReader(path) as reader:
        cycles = list(reader.cycles())
        return cycles, reader.status


def encoded(cycles: list[CycleRecord]) -> list[bytes]:
    return [msgspec.msgpack.encode(cycle) for cycle in cycles]


def write(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def cut_points(first: int, last: int, count: int = 40) -> list[int]:
    """``count`` offsets spread evenly from ``first`` to ``last``, both included."""
    return [first + (last - first) * i // (count - 1) for i in range(count)]
