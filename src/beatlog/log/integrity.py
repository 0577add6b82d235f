"""A session log's records in file order, each checked, and how the file ends.

A log cut off by kill -9 or power loss reads up to its last complete record and ends
in a :class:`TruncatedError` saying where; damage to the index after the cycles (the
summary, the footer, the closing magic) is an :class:`IndexDamageError`; anything else
not as the writer writes it is a :class:`~beatlog.errors.LogError` naming the file.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Iterator
from io import BytesIO
from pathlib import Path
from typing import IO

from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    Footer,
    Header,
    McapRecord,
    Schema,
    Statistics,
)

from beatlog.errors import CorruptLogError, NotABeatlogError
from beatlog.log.container import (
    CHUNK_RECORDS,
    DATA_RECORDS,
    FOOTER_BYTES,
    KNOWN_OPCODES,
    MAGIC,
    RECORD_HEAD,
    SUMMARY_RECORDS,
    RecordDamageError,
    read_record,
    split_records,
    unpack_chunk,
)
from beatlog.log.files import Closing, irregular_file_problem
from beatlog.log.format import DECODE_ERRORS, PROFILE
from beatlog.log.limits import MAX_CHUNK_BYTES, MAX_EXPANSION, MAX_RECORD_BYTES
from beatlog.log.recording import Recording

__all__ = ["IndexDamageError", "RecordStream", "TruncatedError"]


class TruncatedError(Exception):
    """The file ends, or its last record is cut off, before the log was closed."""


class IndexDamageError(Exception):
    """The summary section, the footer or the closing magic is damaged."""


class RecordStream(Closing):
    """The records of one ``.beatlog`` file in file order, chunks opened and checked.

    Opening checks that the path is a regular file (a FIFO or a device could block or
    never end) holding an MCAP container. :meth:`records` yields the data section's
    records; the summary section is kept for :meth:`check_summary`. A
    :class:`~beatlog.log.recording.Recording` is read from the bytes it keeps, or else
    handed every byte read, for its digest and its copy.
    """

    def __init__(self, source: Path | Recording) -> None:
        self.path = Path(source)
        self._recording: Recording | None = None
        if isinstance(source, Recording) and source.digest is None:  # no read has ended
            self._recording = source
            source.start()
        self.file, self.size = self._open(source)
        self.footer: Footer | None = None
        self._summary_crc = 0
        self._chunks: list[tuple[int, int]] = []
        self._expanded = 0
        self._summary_start = 0
        self._summary: list[McapRecord] = []

    def close(self) -> None:
        """Close the file."""
        self.file.close()

    def _read(self, size: int) -> bytes:
        """The next ``size`` bytes of the file (fewer at its end), handed to the recording."""
        piece = self.file.read(size)
        if self._recording is not None:
            self._recording.take(piece)
        return piece

    def finish(self) -> None:
        """Hand the recording the rest of a file whose records ended early (cut off):
        its digest and copy are of every byte, as for a log closed cleanly."""
        if self._recording is None:
            return
        while self._read(1 << 20):
            pass
        self._recording.ended(self.size)

    def _open(self, source: Path | Recording) -> tuple[IO[bytes], int]:
        if isinstance(source, Recording) and source.data is not None:
            kept = BytesIO(source.data)
            kept.seek(len(MAGIC))  # checked as the file was read
            return kept, len(source.data)
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
        self.file = file
        magic = self._read(len(MAGIC))
        if magic != MAGIC:
            file.close()
            what = "empty file" if not magic else "not a session log (not an MCAP file)"
            raise NotABeatlogError(self.path, what)
        return file, size

    def records(self) -> Iterator[McapRecord]:
        """The container's records in file order, up to the footer (the summary checked
        against its CRC there)."""
        size = self.size
        offset = len(MAGIC)
        allowed = DATA_RECORDS | {Opcode.FOOTER}
        while self.footer is None:
            head = self._read(RECORD_HEAD)
            if not head:
                raise TruncatedError("the recording stopped before the log was closed")
            if len(head) < RECORD_HEAD:
                raise TruncatedError(f"the last record is cut off at byte {offset}")
            opcode, length = struct.unpack("<BQ", head)
            end = offset + RECORD_HEAD + length
            if opcode == 0 and not head.strip(b"\0") and self._zero_filled_from(offset):
                raise TruncatedError(f"zero-filled from byte {offset} (power loss?)")
            if end > size:
                if opcode in KNOWN_OPCODES and length <= MAX_RECORD_BYTES:
                    raise TruncatedError(f"the last record is cut off at byte {offset}")
                raise self._damaged_record(f"damaged record at byte {offset}")
            body = self._read(length)
            try:
                if offset > len(MAGIC) and opcode not in allowed:
                    raise RecordDamageError(f"unexpected record (opcode {opcode:#x})")
                records = self._parse(opcode, body, offset)
            except (RecordDamageError, McapError, *DECODE_ERRORS, ValueError, struct.error) as exc:
                if end == size:
                    raise TruncatedError(f"the last record is damaged at byte {offset}") from None
                if self._zero_filled_from(end):
                    raise TruncatedError(
                        f"the last record is damaged at byte {offset}, zero-filled after it "
                        "(power loss?)"
                    ) from None
                problem = f"damaged record at byte {offset}: {exc}"
                raise self._damaged_record(problem) from None
            if offset == len(MAGIC):
                self._check_profile(records)
            if opcode == Opcode.DATA_END:
                allowed = SUMMARY_RECORDS | {Opcode.FOOTER}
                self._summary_start = end
            elif self._summary_start:  # the summary CRC covers the footer but its CRC
                self._summary.extend(records)
                covered = body[: FOOTER_BYTES - 4] if opcode == Opcode.FOOTER else body
                self._summary_crc = zlib.crc32(covered, zlib.crc32(head, self._summary_crc))
            else:
                yield from records
            offset = end
        if self._read(len(MAGIC) + 1) != MAGIC:
            raise IndexDamageError("damaged or extra bytes after the log's footer")
        if self._recording is not None:
            self._recording.ended(size)
        if self.footer.summary_crc != self._summary_crc:
            raise IndexDamageError("the summary does not match its CRC in the footer")

    def _damaged_record(self, problem: str) -> Exception:
        """A record not as written: damage to the index in the summary section, else a
        corrupt log."""
        if self._summary_start:
            return IndexDamageError(problem)
        return CorruptLogError(self.path, problem)

    def _zero_filled_from(self, start: int) -> bool:
        """Whether every byte from ``start`` to the end of the file is zero (power loss)."""
        file = self.file
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
        if opcode == Opcode.MESSAGE_INDEX:  # an index into a chunk just read: not needed
            return []
        record = read_record(opcode, body)
        if isinstance(record, Footer):
            self.footer = record
            return []
        if not isinstance(record, Chunk):
            return [record]
        self._chunks.append((offset, RECORD_HEAD + len(body)))
        data = unpack_chunk(record)
        self._expanded += len(data)
        if self._expanded > MAX_EXPANSION * self.size + MAX_CHUNK_BYTES:
            raise RecordDamageError("chunks decompress to implausibly much data (a zip bomb?)")
        return split_records(data, CHUNK_RECORDS, "a chunk")

    def check_summary(
        self,
        channels: dict[int, Channel],
        schemas: dict[int, Schema],
        messages_read: dict[int, int],
    ) -> None:
        """The summary section must describe exactly the data read: same chunks at the
        same offsets, same message counts, same channels and schemas. A chunk dropped,
        repeated or moved anywhere before it shifts the offsets and is caught here."""
        footer = self.footer
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
        if counts != messages_read or statistics[0].chunk_count != len(self._chunks):
            raise CorruptLogError(self.path, "the summary does not match the messages read")
        for record in self._summary:
            if isinstance(record, Channel) and channels.get(record.id) != record:
                raise CorruptLogError(self.path, f"the summary redefines channel {record.id}")
            if isinstance(record, Schema) and schemas.get(record.id) != record:
                raise CorruptLogError(self.path, f"the summary redefines schema {record.id}")
