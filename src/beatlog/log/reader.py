"""Reads a session log as a stream and checks its integrity on every read.

A log cut off by kill -9 or power loss reads up to its last complete record and
reports where it was truncated. Anything else that is not exactly what the writer
writes is a :class:`~beatlog.errors.LogError` naming the file: a damaged record, a
chunk missing, repeated or out of order, a channel, schema or encoding the format
does not define, an end record that disagrees with the cycles read, a size beyond
:mod:`beatlog.log.limits`, a foreign file or a newer format version. All byte-level
reading of the container happens in this module, with the ``mcap`` package's record
types; payloads are decoded only with msgspec, so nothing in a log can execute code.
``docs/format.md`` lists every check.
"""

from __future__ import annotations

import os
import struct
import threading
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from io import BytesIO
from pathlib import Path
from typing import IO, Any, TypeVar

import msgspec
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
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

from beatlog.closing import Closing
from beatlog.errors import (
    CorruptLogError,
    NotABeatlogError,
    SchemaMismatchError,
    UnsupportedVersionError,
)
from beatlog.files import irregular_file_problem
from beatlog.log.format import (
    CYCLE_BATCH_SINCE,
    CYCLES_TOPIC,
    DECODE_ERRORS,
    END_TOPIC,
    FORMAT_VERSION,
    HEADER_TOPIC,
    MESSAGE_ENCODING,
    PROFILE,
    SCHEMA_ENCODING,
    CycleBatch,
    CycleRecord,
    SessionEnd,
    SessionHeader,
    samples_shape,
    schema_name,
)
from beatlog.log.limits import (
    MAX_CHUNK_BYTES,
    MAX_EXPANSION,
    MAX_RECORD_BYTES,
    MAX_SCHEMA_BYTES,
)

__all__ = ["LogStatus", "SessionLogReader", "recorded_cycles"]

_MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = 9
_FOOTER_BYTES = 20
"""A footer's body: where the summary and its offsets start (8 bytes each), its CRC (4)."""
_FOOTER_RECORD = _RECORD_HEAD + _FOOTER_BYTES
_KNOWN_OPCODES = frozenset(Opcode)
_DATA_RECORDS = frozenset({Opcode.CHUNK, Opcode.MESSAGE_INDEX, Opcode.DATA_END})
_SUMMARY_RECORDS = frozenset(
    {Opcode.SCHEMA, Opcode.CHANNEL, Opcode.STATISTICS, Opcode.CHUNK_INDEX, Opcode.SUMMARY_OFFSET}
)
_CHUNK_RECORDS = frozenset({Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE})
_COMPRESSIONS = ("", "zstd")
_SCHEMAS = {
    HEADER_TOPIC: {schema_name(SessionHeader)},
    CYCLES_TOPIC: {schema_name(CycleBatch), schema_name(CycleRecord)},
    END_TOPIC: {schema_name(SessionEnd)},
}
T = TypeVar("T")


@dataclass(frozen=True)
class LogStatus:
    """How a log ended: closed cleanly, or truncated after ``cycles`` complete cycles.

    A complete log with a ``problem`` has its index (the summary and footer after its
    cycles) damaged and every cycle intact: only a reader told to tolerate that reports
    it. A dataclass rather than a tuple, so that ``replay --json`` names its fields.
    """

    complete: bool
    cycles: int
    problem: str | None = None

    def describe(self) -> str:
        """One line for people: "complete", "index damaged, data intact" and why, or
        where and why the log was truncated."""
        if self.complete:
            return "complete" if self.problem is None else _index_damaged(self.problem)
        return f"truncated at cycle {self.cycles}: {self.problem}"


def _index_damaged(problem: str) -> str:
    return f"index damaged, data intact: {problem}"


class _Versioned(msgspec.Struct):
    format_version: int


class _ReadCycleRecord(CycleRecord, forbid_unknown_fields=True):
    """A cycle record as the reader decodes it: one of more elements than the format
    defines is damaged, not cut short (the writer's own records stay as they are)."""


_ReadCycleBatch: Any = msgspec.defstruct(
    "_ReadCycleBatch",
    [("cycles", list[_ReadCycleRecord])],
    bases=(CycleBatch,),
    array_like=True,
    forbid_unknown_fields=True,
)
"""A cycles message as the reader decodes it: nothing after its cycles, each as read."""


class _RawBatch(msgspec.Struct, array_like=True):
    """A cycles message of format 2 with its cycles still encoded, to find a damaged one."""

    first_cycle: int
    cycles: list[msgspec.Raw]


class _TruncatedError(Exception):
    """Internal: the file ends, or its last record is cut off, before the log was closed."""


class _DamageError(Exception):
    """Internal: a record is not what the writer writes; corrupt unless it is the last."""


class _IndexDamageError(Exception):
    """Internal: the summary section, the footer or the closing magic is damaged."""


class SessionLogReader(Closing):
    """Streams the cycles of one ``.beatlog`` file; a context manager.

    The header is read and checked on opening. Iterate :meth:`batches` (fastest) or
    :meth:`cycles`; when iteration ends, :attr:`status` says whether the log was
    complete. Every cycle yielded is in order, none missing or repeated.

    Damage in the index after the cycles (the summary section and the footer, checked
    against the footer's summary CRC) is a :class:`~beatlog.errors.CorruptLogError`
    even when every cycle and the end record read back intact, unless
    ``tolerate_damaged_index``: the status then says so (for people looking at a log).
    """

    def __init__(self, path: str | Path, *, tolerate_damaged_index: bool = False) -> None:
        self.path = Path(path)
        self._tolerate_damaged_index = tolerate_damaged_index
        self._file, self._size = self._open()
        self._channels: dict[int, Channel] = {}
        self._topics: dict[str, int] = {}
        self._schemas: dict[int, Schema] = {}
        self._cycles = 0
        self._robot_time_ns = 0
        self._end: SessionEnd | None = None
        self._status: LogStatus | None = None
        self._expanded = 0
        self._chunks: list[tuple[int, int]] = []
        self._messages_read: dict[int, int] = {}
        self._summary_start = 0
        self._summary_crc = 0
        self._footer: Footer | None = None
        self._summary: list[McapRecord] = []
        self._messages = self._topic_messages()
        try:
            self.header = self._read_header()
        except BaseException:
            self.close()
            raise
        self.format_version = self.header.format_version
        self._raw_batches: Any = msgspec.msgpack.Decoder(
            _ReadCycleBatch if self.format_version >= CYCLE_BATCH_SINCE else list[_ReadCycleRecord]
        )
        self._batch_decoder: Any = self._raw_batches
        self._state_type: type[Any] | None = None

    @property
    def status(self) -> LogStatus:
        """Whether the log closed cleanly; known once iteration has reached its end."""
        if self._status is None:
            raise RuntimeError("the log's status is known only after reading all its cycles")
        return self._status

    @property
    def robot_time_ns(self) -> int:
        """The robot time of the cycles read so far: the sum of their heartbeat intervals."""
        return self._robot_time_ns

    @property
    def end(self) -> SessionEnd | None:
        """The end record, if the recording closed cleanly."""
        return self._end

    def batches(self) -> Iterator[list[CycleRecord]]:
        """Yield the cycles in the batches they were written in, each checked in place."""
        for topic, message in self._messages:
            if topic == CYCLES_TOPIC:
                yield self._batch(message)
            elif topic == END_TOPIC:
                self._read_end(message)
            else:
                raise CorruptLogError(self.path, "a second session header")

    def decode_states(self, state_type: type[Any]) -> None:
        """Decode each cycle's RS_t into ``state_type`` from the next batch on, with the
        batch itself: the records' ``robot_state`` is then the decoded state, not its bytes,
        and their ``samples`` are checked against the header (:func:`samples_shape`), not
        kept.

        Decoding in the same pass as the batch reads every robot state once instead of
        skipping it and decoding it again. A robot state that does not fit the type is a
        :class:`~beatlog.errors.SchemaMismatchError` naming its cycle; samples the header
        does not declare are a :class:`~beatlog.errors.CorruptLogError` naming it.
        """
        record: Any = msgspec.defstruct(
            "DecodedCycleRecord",
            [("robot_state", state_type), ("samples", samples_shape(self.header))],
            bases=(_ReadCycleRecord,),
            array_like=True,
        )
        batch: Any = (
            msgspec.defstruct(
                "DecodedCycleBatch",
                [("cycles", list[record])],
                bases=(_ReadCycleBatch,),
                array_like=True,
            )
            if self.format_version >= CYCLE_BATCH_SINCE
            else list[record]
        )
        self._batch_decoder = msgspec.msgpack.Decoder(batch)
        self._state_type = state_type

    def cycles(self) -> Iterator[CycleRecord]:
        """Yield every cycle in order."""
        for batch in self.batches():
            yield from batch

    def close(self) -> None:
        """Close the file."""
        self._file.close()

    def _open(self) -> tuple[IO[bytes], int]:
        """Open a regular file only: a FIFO or a device could block or never end."""
        problem = irregular_file_problem(self.path)
        if problem is not None:
            if problem == "is a directory":
                problem = "is a directory, not a session log"
            raise NotABeatlogError(self.path, problem)
        try:
            file = self.path.open("rb")
        except OSError as exc:
            raise NotABeatlogError(self.path, f"cannot open: {exc.strerror}") from None
        size = os.fstat(file.fileno()).st_size
        magic = file.read(len(_MAGIC))
        if magic != _MAGIC:
            file.close()
            what = "empty file" if not magic else "not a session log (not an MCAP file)"
            raise NotABeatlogError(self.path, what)
        return file, size

    def _read_header(self) -> SessionHeader:
        try:
            topic, message = next(self._messages)
        except StopIteration:
            raise CorruptLogError(self.path, "cut off before its session header") from None
        if topic != HEADER_TOPIC:
            raise CorruptLogError(self.path, f"first message is on {topic!r}, not the header")
        missing = sorted(set(_SCHEMAS) - set(self._topics))
        if missing:
            raise CorruptLogError(self.path, f"no {', '.join(missing)} channel")
        if message.log_time != 0:
            raise CorruptLogError(self.path, "the session header is not stamped at time 0")
        if len(message.data) > MAX_SCHEMA_BYTES:
            raise CorruptLogError(
                self.path,
                f"damaged session header: {len(message.data)} bytes, more than the "
                f"{MAX_SCHEMA_BYTES} a header may hold",
            )
        version = self._decode(message.data, _Versioned, "session header").format_version
        if version > FORMAT_VERSION:
            raise UnsupportedVersionError(
                self.path,
                f"written in format version {version}; this beatlog reads up to "
                f"{FORMAT_VERSION} (upgrade beatlog)",
            )
        header = self._decode(message.data, SessionHeader, "session header")
        if (problem := header.problem()) is not None:
            raise CorruptLogError(self.path, f"damaged session header: {problem}")
        expected = schema_name(CycleBatch if version >= CYCLE_BATCH_SINCE else CycleRecord)
        cycles = self._topics.get(CYCLES_TOPIC)
        found = None if cycles is None else self._schemas[self._channels[cycles].schema_id].name
        if found != expected:
            raise CorruptLogError(
                self.path,
                f"cycles have schema {found!r}, not the {expected!r} of format version {version}",
            )
        return header

    def _batch(self, message: Message) -> list[CycleRecord]:
        """Decode one cycles message and check it continues exactly where the last ended."""
        where = f"the batch after cycle {self._cycles}"
        try:
            decoded = self._batch_decoder.decode(message.data)
        except DECODE_ERRORS as exc:
            raise self._batch_problem(message.data, where, exc) from None
        if isinstance(decoded, CycleBatch):
            if decoded.first_cycle != self._cycles:
                raise CorruptLogError(
                    self.path,
                    f"cycles out of order: a batch starts at cycle {decoded.first_cycle} "
                    f"where cycle {self._cycles} is next (a chunk missing, repeated or moved)",
                )
            batch = decoded.cycles
        else:
            batch = decoded
        if not batch:
            raise CorruptLogError(self.path, f"{where} is empty")
        if message.log_time != self._robot_time_ns + batch[0].heartbeat_ns:
            raise CorruptLogError(
                self.path,
                f"cycles out of order: {where} is stamped {message.log_time} ns of robot "
                f"time, not {self._robot_time_ns + batch[0].heartbeat_ns} "
                "(a chunk missing, repeated or moved)",
            )
        self._cycles += len(batch)
        self._robot_time_ns += sum([cycle.heartbeat_ns for cycle in batch])
        return batch

    def _batch_problem(self, data: bytes, where: str, exc: Exception) -> Exception:
        """What is wrong with a batch that did not decode: a cycle in it is damaged, the
        batch itself is, or (when robot states are decoded with it) a cycle's robot state
        does not fit its type or its samples are not what the header declares."""
        try:
            decoded = self._raw_batches.decode(data)
        except DECODE_ERRORS as damage:
            return self._damaged_cycle(data) or CorruptLogError(
                self.path, f"damaged {where}: {damage}"
            )
        state_type = self._state_type
        assert state_type is not None  # raw batches decoded above: states did not
        records = decoded.cycles if isinstance(decoded, CycleBatch) else decoded
        samples = samples_shape(self.header)
        for index, record in enumerate(records):
            try:
                msgspec.msgpack.decode(record.robot_state, type=state_type)
            except DECODE_ERRORS as misfit:
                return SchemaMismatchError(
                    self.path,
                    f"robot state of cycle {self._cycles + index} does not fit "
                    f"{state_type.__name__}: {misfit}",
                )
            try:
                msgspec.msgpack.decode(record.samples, type=samples)
            except DECODE_ERRORS as misfit:
                logged = "samples" if self.header.samples_logged else "no samples"
                return CorruptLogError(
                    self.path,
                    f"damaged samples in cycle {self._cycles + index}: the header declares "
                    f"{logged}: {misfit}",
                )
        return CorruptLogError(self.path, f"damaged {where}: {exc}")

    def _damaged_cycle(self, data: bytes) -> CorruptLogError | None:
        """The first cycle of a batch that is not a cycle record, when the batch holds an
        array of cycles at all."""
        try:
            if self.format_version >= CYCLE_BATCH_SINCE:
                records = msgspec.msgpack.decode(data, type=_RawBatch).cycles
            else:
                records = msgspec.msgpack.decode(data, type=list[msgspec.Raw])
        except DECODE_ERRORS:
            return None
        for index, record in enumerate(records):
            try:
                msgspec.msgpack.decode(record, type=_ReadCycleRecord)
            except DECODE_ERRORS as damage:
                return CorruptLogError(self.path, f"damaged cycle {self._cycles + index}: {damage}")
        return None

    def _read_end(self, message: Message) -> None:
        end = self._decode(message.data, SessionEnd, "end record")
        if message.log_time != end.robot_time_ns:
            raise CorruptLogError(
                self.path, "the end record is not stamped with the session's robot time"
            )
        if (end.cycles, end.robot_time_ns) != (self._cycles, self._robot_time_ns):
            raise CorruptLogError(
                self.path,
                f"the end record counts {end.cycles} cycles and {end.robot_time_ns} ns of "
                f"robot time, but the log holds {self._cycles} cycles and "
                f"{self._robot_time_ns} ns",
            )
        self._end = end

    def _decode(self, data: bytes, kind: type[T], what: str) -> T:
        try:
            return msgspec.msgpack.decode(data, type=kind)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(self.path, f"damaged {what}: {exc}") from None

    def _topic_messages(self) -> Iterator[tuple[str, Message]]:
        """Messages with their channel's topic, in the order the format requires.

        The header comes first, then cycles, then at most one end record and nothing
        after it. Sets the status when the records end.
        """
        ended = False
        try:
            for record in self._records():
                if isinstance(record, Message):
                    channel = self._channels.get(record.channel_id)
                    if channel is None:
                        raise CorruptLogError(
                            self.path, f"message on unknown channel {record.channel_id}"
                        )
                    if ended:
                        raise CorruptLogError(self.path, "a message after the end record")
                    count = self._messages_read.get(channel.id, 0)
                    self._messages_read[channel.id] = count + 1
                    ended = channel.topic == END_TOPIC
                    yield channel.topic, record
                elif isinstance(record, Schema):
                    self._add_schema(record)
                elif isinstance(record, Channel):
                    self._add_channel(record)
        except _TruncatedError as cut:
            self._status = LogStatus(False, self._cycles, str(cut))
            return
        except _IndexDamageError as damage:
            self._index_damage(str(damage))
            return
        assert self._footer is not None  # the records end with the footer
        if self._footer.summary_crc != self._summary_crc:
            self._index_damage("the summary does not match its CRC in the footer")
            return
        self._check_summary()
        if self._end is None:
            self._status = LogStatus(False, self._cycles, "the log has no end record")
        else:
            self._status = LogStatus(True, self._cycles)

    def _index_damage(self, problem: str) -> None:
        """The summary or footer is damaged: after intact cycles and end record, the
        status of a reader tolerating that, else an error."""
        if self._end is None:
            raise CorruptLogError(self.path, problem)
        if not self._tolerate_damaged_index:
            raise CorruptLogError(self.path, _index_damaged(problem))
        self._status = LogStatus(True, self._cycles, problem)

    def _add_schema(self, schema: Schema) -> None:
        known = self._schemas.get(schema.id)
        if known is not None:
            if known != schema:
                raise CorruptLogError(self.path, f"schema {schema.id} is defined twice")
            return
        if schema.encoding != SCHEMA_ENCODING or not any(
            schema.name in names for names in _SCHEMAS.values()
        ):
            raise CorruptLogError(
                self.path,
                f"foreign schema {schema.name!r} ({schema.encoding or 'no encoding'}) "
                "in a session log",
            )
        self._schemas[schema.id] = schema

    def _add_channel(self, channel: Channel) -> None:
        known = self._channels.get(channel.id)
        if known is not None:
            if known != channel:
                raise CorruptLogError(self.path, f"channel {channel.id} is defined twice")
            return
        schema = self._schemas.get(channel.schema_id)
        if channel.topic not in _SCHEMAS or channel.topic in self._topics:
            what = "a second" if channel.topic in self._topics else "a foreign"
            raise CorruptLogError(self.path, f"{what} channel {channel.topic!r} in a session log")
        if channel.message_encoding != MESSAGE_ENCODING:
            raise CorruptLogError(
                self.path,
                f"channel {channel.topic!r} has encoding {channel.message_encoding!r}, "
                f"not {MESSAGE_ENCODING!r}",
            )
        if schema is None or schema.name not in _SCHEMAS[channel.topic]:
            raise CorruptLogError(
                self.path, f"channel {channel.topic!r} has no schema the format defines for it"
            )
        self._channels[channel.id] = channel
        self._topics[channel.topic] = channel.id

    def _records(self) -> Iterator[McapRecord]:
        """The container's records in file order, chunks opened and checked."""
        file = self._file
        size = self._size
        offset = len(_MAGIC)
        first = True
        summary = False
        allowed = _DATA_RECORDS | {Opcode.FOOTER}
        while self._footer is None:
            head = file.read(_RECORD_HEAD)
            if not head:
                raise _TruncatedError("the recording stopped before the log was closed")
            if len(head) < _RECORD_HEAD:
                raise _TruncatedError(f"the last record is cut off at byte {offset}")
            opcode, length = struct.unpack("<BQ", head)
            end = offset + _RECORD_HEAD + length
            if opcode == 0 and not head.strip(b"\0") and self._zero_filled_from(offset):
                raise _TruncatedError(f"zero-filled from byte {offset} (power loss?)")
            if end > size:
                if opcode in _KNOWN_OPCODES and length <= MAX_RECORD_BYTES:
                    raise _TruncatedError(f"the last record is cut off at byte {offset}")
                raise self._damaged_record(f"damaged record at byte {offset}", summary=summary)
            body = file.read(length)
            try:
                if not first and opcode not in allowed:
                    raise _DamageError(f"unexpected record (opcode {opcode:#x})")
                records = self._parse(opcode, body, offset)
            except (_DamageError, McapError, *DECODE_ERRORS, ValueError, struct.error) as exc:
                if end == size:
                    raise _TruncatedError(f"the last record is damaged at byte {offset}") from None
                if self._zero_filled_from(end):
                    raise _TruncatedError(
                        f"the last record is damaged at byte {offset}, zero-filled after it "
                        "(power loss?)"
                    ) from None
                problem = f"damaged record at byte {offset}: {exc}"
                raise self._damaged_record(problem, summary=summary) from None
            if first:
                self._check_profile(records)
                first = False
            if opcode == Opcode.DATA_END:
                allowed = _SUMMARY_RECORDS | {Opcode.FOOTER}
                self._summary_start = end
                summary = True
            elif summary:
                self._summary.extend(records)
                self._summary_crc = _summary_crc(head, body, self._summary_crc)
            else:
                yield from records
            offset = end
        if file.read(len(_MAGIC) + 1) != _MAGIC:
            raise _IndexDamageError("damaged or extra bytes after the log's footer")

    def _damaged_record(self, problem: str, *, summary: bool) -> Exception:
        """A record not as written: damage to the index in the summary section, else a
        corrupt log."""
        return _IndexDamageError(problem) if summary else CorruptLogError(self.path, problem)

    def _zero_filled_from(self, start: int) -> bool:
        """Whether every byte from ``start`` to the end of the file is zero (power loss)."""
        file = self._file
        position = file.tell()
        file.seek(start)
        try:
            while block := file.read(1 << 20):
                if block.strip(b"\0"):
                    return False
            return True
        finally:
            file.seek(position)

    def _check_profile(self, records: list[McapRecord]) -> None:
        header = records[0] if records else None
        if not isinstance(header, Header):
            raise CorruptLogError(self.path, "MCAP file does not start with a header record")
        if header.profile != PROFILE:
            profile = header.profile or "none"
            raise NotABeatlogError(
                self.path, f"an MCAP file with profile {profile!r}, not a beatlog session log"
            )

    def _parse(self, opcode: int, body: bytes, offset: int) -> list[McapRecord]:
        if opcode == Opcode.CHUNK:
            chunk = _read_chunk(body)
            self._chunks.append((offset, _RECORD_HEAD + len(body)))
            return self._chunk_records(chunk)
        if opcode == Opcode.MESSAGE_INDEX:  # an index into a chunk just read: not needed
            return []
        if opcode == Opcode.CHUNK_INDEX:
            return [_read_chunk_index(body)]
        stream = ReadDataStream(BytesIO(body))
        if opcode == Opcode.HEADER:
            return [Header.read(stream)]
        if opcode == Opcode.FOOTER:
            self._footer = Footer.read(stream)
            return []
        reader = _TOP_LEVEL.get(Opcode(opcode)) if opcode in _KNOWN_OPCODES else None
        if reader is None:
            raise _DamageError(f"unknown record opcode {opcode:#x}")
        return [reader(stream)]

    def _chunk_records(self, chunk: Chunk) -> list[McapRecord]:
        """Open a chunk within the bounds, the file's included, and split it into its
        records."""
        _check_chunk_bounds(chunk)
        self._expanded += chunk.uncompressed_size
        if self._expanded > MAX_EXPANSION * self._size + MAX_CHUNK_BYTES:
            raise _DamageError("chunks decompress to implausibly much data (a zip bomb?)")
        return _split_records(_unpack_chunk(chunk), _CHUNK_RECORDS, "a chunk")

    def _check_summary(self) -> None:
        """The summary section must describe exactly the data read: same chunks at the
        same offsets, same message counts, same channels. A chunk dropped, repeated or
        moved anywhere before it shifts the offsets and is caught here."""
        footer = self._footer
        assert footer is not None
        if footer.summary_start != self._summary_start:
            raise CorruptLogError(
                self.path,
                f"the footer places the summary at byte {footer.summary_start}, but it is "
                f"at byte {self._summary_start} (bytes missing or added before it)",
            )
        indexed = sorted(
            (r.chunk_start_offset, r.chunk_length)
            for r in self._summary
            if isinstance(r, ChunkIndex)
        )
        statistics = [r for r in self._summary if isinstance(r, Statistics)]
        if indexed != self._chunks or len(statistics) != 1:
            raise CorruptLogError(self.path, "the summary does not match the chunks read")
        counts = {k: v for k, v in statistics[0].channel_message_counts.items() if v}
        if counts != self._messages_read or statistics[0].chunk_count != len(self._chunks):
            raise CorruptLogError(self.path, "the summary does not match the messages read")
        for record in self._summary:
            if isinstance(record, Channel) and self._channels.get(record.id) != record:
                raise CorruptLogError(self.path, f"the summary redefines channel {record.id}")
            if isinstance(record, Schema) and self._schemas.get(record.id) != record:
                raise CorruptLogError(self.path, f"the summary redefines schema {record.id}")


def recorded_cycles(path: str | Path) -> int | None:
    """The cycles the end record of a closed log counts, or None where there is none to
    read cheaply: the log was cut off, is damaged, or is no session log.

    Only the footer, the summary section (checked against the footer's CRC) and the
    chunk that holds the end record are read, each within the bounds of
    :mod:`beatlog.log.limits`: a cost that does not grow with the recording, for
    planning work such as splitting a suite into shards. Nothing else is checked;
    judging a log is :class:`SessionLogReader`'s job.
    """
    path = Path(path)
    if irregular_file_problem(path) is not None:
        return None
    try:
        with path.open("rb") as file:
            return _end_record_cycles(file, os.fstat(file.fileno()).st_size)
    except (OSError, McapError, _DamageError, ValueError, struct.error, *DECODE_ERRORS):
        return None


def _end_record_cycles(file: IO[bytes], size: int) -> int | None:
    """The end record's cycle count, found through the footer and the summary's index."""
    footer_at = size - len(_MAGIC) - _FOOTER_RECORD
    if footer_at <= len(_MAGIC) or file.read(len(_MAGIC)) != _MAGIC:
        return None
    file.seek(footer_at)
    tail = file.read(_FOOTER_RECORD + len(_MAGIC))
    opcode, length = struct.unpack_from("<BQ", tail)
    if (opcode, length, tail[_FOOTER_RECORD:]) != (Opcode.FOOTER, _FOOTER_BYTES, _MAGIC):
        return None
    summary_start = Footer.read(ReadDataStream(BytesIO(tail[_RECORD_HEAD:]))).summary_start
    if not len(_MAGIC) < summary_start <= footer_at or footer_at - summary_start > MAX_CHUNK_BYTES:
        return None
    file.seek(summary_start)
    section = file.read(footer_at - summary_start)
    footer = tail[:_FOOTER_RECORD]
    if zlib.crc32(footer[:-4], zlib.crc32(section)) != int.from_bytes(footer[-4:], "little"):
        return None
    summary = _split_records(section, _SUMMARY_RECORDS, "the summary")
    ends = {r.id for r in summary if isinstance(r, Channel) and r.topic == END_TOPIC}
    # A chunk holds at most MAX_CHUNK_BYTES, and compression never doubles it.
    holding = [
        r.chunk_start_offset
        for r in summary
        if isinstance(r, ChunkIndex)
        and not ends.isdisjoint(r.message_index_offsets)
        and r.chunk_length <= 2 * MAX_CHUNK_BYTES
        and r.chunk_start_offset + r.chunk_length <= summary_start
    ]
    if len(ends) != 1 or len(holding) != 1:
        return None
    file.seek(holding[0])
    opcode, length = struct.unpack("<BQ", file.read(_RECORD_HEAD))
    if opcode != Opcode.CHUNK or length > 2 * MAX_CHUNK_BYTES:
        return None
    chunk = Chunk.read(ReadDataStream(BytesIO(file.read(length))))
    _check_chunk_bounds(chunk)
    records = _split_records(_unpack_chunk(chunk), _CHUNK_RECORDS, "a chunk")
    end = [r for r in records if isinstance(r, Message) and r.channel_id in ends]
    if len(end) != 1:
        return None
    return msgspec.msgpack.decode(end[0].data, type=SessionEnd).cycles


def _summary_crc(head: bytes, body: bytes, crc: int) -> int:
    """The summary CRC so far, given one more record after the data section: all of it,
    or of the footer the fields before the CRC itself (as MCAP defines it)."""
    crc = zlib.crc32(head, crc)
    if head[0] == Opcode.FOOTER:
        return zlib.crc32(body[: _FOOTER_BYTES - 4], crc)
    return zlib.crc32(body, crc)


_CHUNK_HEAD = struct.Struct("<QQQII")
"""A chunk's fixed fields: start and end time, uncompressed size and CRC, the length
of its compression's name."""


def _read_chunk(body: bytes) -> Chunk:
    """A chunk record's fields, read with ``struct`` (the hot path: one per batch)."""
    start, end, size, crc, name_length = _CHUNK_HEAD.unpack_from(body)
    at = _CHUNK_HEAD.size + name_length
    compression = str(body[_CHUNK_HEAD.size : at], "utf-8")
    (length,) = struct.unpack_from("<Q", body, at)
    data = body[at + 8 :]
    if len(data) != length:
        raise _DamageError(f"a chunk holds {len(data)} bytes of records where it declares {length}")
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


def _read_chunk_index(body: bytes) -> ChunkIndex:
    """A chunk index record's fields, read with ``struct`` (the summary holds one a chunk)."""
    start, end, chunk_at, chunk_length, offsets_length = _INDEX_HEAD.unpack_from(body)
    at = _INDEX_HEAD.size
    if offsets_length % _INDEX_OFFSET.size:
        raise _DamageError("a chunk index with a damaged message index offset")
    offsets = dict(_INDEX_OFFSET.iter_unpack(body[at : at + offsets_length]))
    at += offsets_length
    index_length, name_length = _INDEX_TAIL.unpack_from(body, at)
    at += _INDEX_TAIL.size
    compression = str(body[at : at + name_length], "utf-8")
    at += name_length
    compressed, uncompressed = _INDEX_SIZES.unpack_from(body, at)
    if at + _INDEX_SIZES.size != len(body):
        raise _DamageError(f"a chunk index has {len(body) - at - _INDEX_SIZES.size} extra bytes")
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


def _check_chunk_bounds(chunk: Chunk) -> None:
    """A chunk must use a compression the format allows and stay within one chunk's size."""
    if chunk.compression not in _COMPRESSIONS:
        raise _DamageError(f"unknown chunk compression {chunk.compression!r}")
    if chunk.uncompressed_size > MAX_CHUNK_BYTES:
        raise _DamageError(f"a chunk claims {chunk.uncompressed_size} bytes uncompressed")


_THREAD = threading.local()


def _decompressor() -> zstandard.ZstdDecompressor:
    """This thread's zstd decompressor (one may not serve two threads at once)."""
    found: zstandard.ZstdDecompressor | None = getattr(_THREAD, "decompressor", None)
    if found is None:
        found = _THREAD.decompressor = zstandard.ZstdDecompressor()
    return found


def _unpack_chunk(chunk: Chunk) -> bytes:
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
            raise _DamageError(f"chunk does not decompress: {exc}") from None
    if len(data) != size:
        raise _DamageError(f"chunk holds {len(data)} bytes where it declares {size}")
    if zlib.crc32(data) != chunk.uncompressed_crc:
        raise _DamageError("chunk CRC mismatch")
    return data


def _split_records(data: bytes, allowed: frozenset[int], where: str) -> list[McapRecord]:
    """The records packed in ``data`` (an opened chunk, the summary section), each of a kind
    in ``allowed``."""
    records: list[McapRecord] = []
    position = 0
    while position < len(data):
        if position + _RECORD_HEAD > len(data):
            raise _DamageError(f"a record inside {where} is cut off")
        opcode, length = struct.unpack_from("<BQ", data, position)
        start = position + _RECORD_HEAD
        position = start + length
        if opcode not in allowed or position > len(data):
            raise _DamageError(f"a damaged record inside {where} (opcode {opcode:#x})")
        if opcode == Opcode.MESSAGE:  # the common case, read without a stream
            if length < _MESSAGE_HEAD.size:
                raise _DamageError(f"a message inside {where} is cut off")
            channel, sequence, log_time, publish_time = _MESSAGE_HEAD.unpack_from(data, start)
            body = data[start + _MESSAGE_HEAD.size : position]
            records.append(Message(channel, log_time, body, publish_time, sequence))
            continue
        if opcode == Opcode.CHUNK_INDEX:  # one a chunk
            records.append(_read_chunk_index(data[start:position]))
            continue
        stream = ReadDataStream(BytesIO(data[start:position]))
        records.append(_TOP_LEVEL[Opcode(opcode)](stream))
        if stream.count != length:
            raise _DamageError(f"a record inside {where} has {length - stream.count} extra bytes")
    return records


_MESSAGE_HEAD = struct.Struct("<HIQQ")
"""A message record's fixed fields: channel id, sequence, log time, publish time."""


_TOP_LEVEL = {
    Opcode.MESSAGE_INDEX: MessageIndex.read,
    Opcode.DATA_END: DataEnd.read,
    Opcode.SCHEMA: Schema.read,
    Opcode.CHANNEL: Channel.read,
    Opcode.STATISTICS: Statistics.read,
    Opcode.SUMMARY_OFFSET: SummaryOffset.read,
}
