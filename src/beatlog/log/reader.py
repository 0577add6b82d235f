"""Reads a session log as a stream, never needing the summary section at the end.

A log cut off by kill -9 or power loss reads up to its last complete record and
reports where it was truncated; a damaged record before the end, a foreign file or a
newer format version is a :class:`~beatlog.errors.LogError` that names the file.
All byte-level reading of the container happens in :meth:`SessionLogReader._records`,
using the ``mcap`` package's record types; payloads are decoded only with msgspec,
so nothing in a log can execute code.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from io import BytesIO
from pathlib import Path
from types import TracebackType
from typing import IO, NamedTuple, TypeVar

import msgspec
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Footer, Header, McapRecord, Message
from mcap.stream_reader import breakup_chunk

from beatlog.errors import CorruptLogError, NotABeatlogError, UnsupportedVersionError
from beatlog.log.format import (
    CYCLES_TOPIC,
    END_TOPIC,
    FORMAT_VERSION,
    HEADER_TOPIC,
    PROFILE,
    CycleRecord,
    SessionEnd,
    SessionHeader,
)

__all__ = ["LogStatus", "SessionLogReader"]

_MAGIC = b"\x89MCAP0\r\n"
_MAX_CHUNK_BYTES = 1 << 30
_COMPRESSIONS = ("", "zstd", "lz4")
_KNOWN_OPCODES = frozenset(Opcode)
_FIRST_USER_OPCODE = 0x80
T = TypeVar("T")


class LogStatus(NamedTuple):
    """How a log ended: closed cleanly, or truncated after ``cycles`` complete cycles."""

    complete: bool
    cycles: int
    problem: str | None = None

    def describe(self) -> str:
        """One line for people: "complete" or where and why the log was truncated."""
        if self.complete:
            return "complete"
        return f"truncated at cycle {self.cycles}: {self.problem}"


class _Versioned(msgspec.Struct):
    format_version: int


class _TruncatedError(Exception):
    """Internal: the file ends, or its last record is cut off, before the log was closed."""


class SessionLogReader:
    """Streams the cycles of one ``.beatlog`` file; a context manager.

    The header is read on opening. Iterate :meth:`batches` (fastest) or :meth:`cycles`;
    when iteration ends, :attr:`status` says whether the log was complete.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._file = self._open()
        self._channels: dict[int, str] = {}
        self._cycles = 0
        self._end: SessionEnd | None = None
        self._footer = False
        self._status: LogStatus | None = None
        self._batch_decoder = msgspec.msgpack.Decoder(list[CycleRecord])
        self._messages = self._topic_messages()
        try:
            self.header = self._read_header()
        except BaseException:
            self.close()
            raise

    @property
    def status(self) -> LogStatus:
        """Whether the log closed cleanly; known once iteration has reached its end."""
        if self._status is None:
            raise RuntimeError("the log's status is known only after reading all its cycles")
        return self._status

    @property
    def end(self) -> SessionEnd | None:
        """The end record, if the recording closed cleanly."""
        return self._end

    def batches(self) -> Iterator[list[CycleRecord]]:
        """Yield the cycles in the batches they were written in."""
        for topic, message in self._messages:
            if topic == CYCLES_TOPIC:
                try:
                    batch = self._batch_decoder.decode(message.data)
                except msgspec.DecodeError as exc:
                    raise CorruptLogError(
                        self.path, f"damaged cycle batch after cycle {self._cycles}: {exc}"
                    ) from None
                self._cycles += len(batch)
                yield batch
            elif topic == END_TOPIC:
                self._end = self._decode(message.data, SessionEnd, "end record")

    def cycles(self) -> Iterator[CycleRecord]:
        """Yield every cycle in order."""
        for batch in self.batches():
            yield from batch

    def close(self) -> None:
        """Close the file."""
        self._file.close()

    def __enter__(self) -> SessionLogReader:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _open(self) -> IO[bytes]:
        try:
            file = self.path.open("rb")
        except FileNotFoundError:
            raise NotABeatlogError(self.path, "no such file") from None
        except IsADirectoryError:
            raise NotABeatlogError(self.path, "is a directory, not a session log") from None
        except OSError as exc:
            raise NotABeatlogError(self.path, f"cannot open: {exc.strerror}") from None
        magic = file.read(len(_MAGIC))
        if magic != _MAGIC:
            file.close()
            what = "empty file" if not magic else "not a session log (not an MCAP file)"
            raise NotABeatlogError(self.path, what)
        return file

    def _read_header(self) -> SessionHeader:
        try:
            topic, message = next(self._messages)
        except StopIteration:
            raise CorruptLogError(self.path, "cut off before its session header") from None
        if topic != HEADER_TOPIC:
            raise CorruptLogError(self.path, f"first message is on {topic!r}, not the header")
        version = self._decode(message.data, _Versioned, "session header").format_version
        if version > FORMAT_VERSION:
            raise UnsupportedVersionError(
                self.path,
                f"written in format version {version}; this beatlog reads up to "
                f"{FORMAT_VERSION} (upgrade beatlog)",
            )
        return self._decode(message.data, SessionHeader, "session header")

    def _decode(self, data: bytes, kind: type[T], what: str) -> T:
        try:
            return msgspec.msgpack.decode(data, type=kind)
        except msgspec.DecodeError as exc:
            raise CorruptLogError(self.path, f"damaged {what}: {exc}") from None

    def _topic_messages(self) -> Iterator[tuple[str, Message]]:
        """Messages with their channel's topic; sets the status when the records end."""
        try:
            for record in self._records():
                if isinstance(record, Message):
                    topic = self._channels.get(record.channel_id)
                    if topic is None:
                        raise CorruptLogError(
                            self.path, f"message on unknown channel {record.channel_id}"
                        )
                    yield topic, record
                elif isinstance(record, Channel):
                    self._channels[record.id] = record.topic
        except _TruncatedError as cut:
            self._status = LogStatus(False, self._cycles, str(cut))
            return
        if self._end is None:
            self._status = LogStatus(False, self._cycles, "the log has no end record")
        else:
            self._status = LogStatus(True, self._cycles)

    def _records(self) -> Iterator[McapRecord]:
        """The container's records in file order, chunks opened, CRCs checked."""
        file = self._file
        size = self.path.stat().st_size
        offset = len(_MAGIC)
        first = True
        while not self._footer:
            head = file.read(9)
            if not head:
                raise _TruncatedError("the recording stopped before the log was closed")
            if len(head) < 9:
                raise _TruncatedError(f"the last record is cut off at byte {offset}")
            opcode, length = struct.unpack("<BQ", head)
            end = offset + 9 + length
            if opcode == 0 and not head.strip(b"\0") and self._zero_filled_from(offset):
                raise _TruncatedError(f"zero-filled from byte {offset} (power loss?)")
            if end > size:
                if opcode in _KNOWN_OPCODES and length <= _MAX_CHUNK_BYTES:
                    raise _TruncatedError(f"the last record is cut off at byte {offset}")
                raise CorruptLogError(self.path, f"damaged record at byte {offset}")
            body = file.read(length)
            try:
                records = self._parse(opcode, body)
            except Exception as exc:
                if end == size:
                    raise _TruncatedError(f"the last record is damaged at byte {offset}") from None
                if self._zero_filled_from(end):
                    raise _TruncatedError(
                        f"the last record is damaged at byte {offset}, zero-filled after it "
                        "(power loss?)"
                    ) from None
                raise CorruptLogError(
                    self.path, f"damaged record at byte {offset}: {exc}"
                ) from None
            if first:
                self._check_profile(records)
                first = False
            yield from records
            offset = end

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

    def _parse(self, opcode: int, body: bytes) -> list[McapRecord]:
        stream = ReadDataStream(BytesIO(body))
        if opcode == Opcode.CHUNK:
            chunk = Chunk.read(stream)
            if chunk.uncompressed_size > _MAX_CHUNK_BYTES or chunk.compression not in _COMPRESSIONS:
                raise ValueError("implausible chunk")
            return breakup_chunk(chunk, validate_crc=True)
        if opcode == Opcode.MESSAGE:
            return [Message.read(stream, len(body))]
        if opcode == Opcode.CHANNEL:
            return [Channel.read(stream)]
        if opcode == Opcode.HEADER:
            return [Header.read(stream)]
        if opcode == Opcode.FOOTER:
            self._footer = True
            return [Footer.read(stream)]
        if opcode in _KNOWN_OPCODES or opcode >= _FIRST_USER_OPCODE:
            return []
        raise ValueError(f"unknown record opcode {opcode:#x}")
