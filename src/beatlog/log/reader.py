"""Reads a session log as a stream of cycles, with the session's semantics checked.

The header comes first and must describe a log this beatlog reads; the cycles follow
in order, none missing or repeated, each batch stamped with its robot time; an end
record, if any, counts exactly the cycles read (``docs/format.md`` lists every check).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.records import Channel, Message, Schema

from beatlog.errors import CorruptLogError, UnsupportedVersionError
from beatlog.log.files import Closing
from beatlog.log.format import (
    CYCLES_TOPIC,
    DECODE_ERRORS,
    END_TOPIC,
    FORMAT_VERSION,
    HEADER_TOPIC,
    MESSAGE_ENCODING,
    SCHEMA_ENCODING,
    ColumnBatch,
    CycleBatch,
    CycleRecord,
    SessionEnd,
    SessionHeader,
    cycles_record,
    schema_name,
)
from beatlog.log.integrity import IndexDamageError, RecordStream, TruncatedError
from beatlog.log.limits import MAX_SCHEMA_BYTES
from beatlog.log.payload import BatchDecoding, decode_payload, decoded_version
from beatlog.log.recording import LogSource, Recording

__all__ = ["LogStatus", "SessionLogReader"]

_SCHEMAS = {
    HEADER_TOPIC: {schema_name(SessionHeader)},
    CYCLES_TOPIC: {schema_name(ColumnBatch), schema_name(CycleBatch), schema_name(CycleRecord)},
    END_TOPIC: {schema_name(SessionEnd)},
}


@dataclass(frozen=True)
class LogStatus:
    """How a log ended: closed cleanly, or truncated after ``cycles`` complete cycles; a
    complete log with a ``problem`` has its index damaged and every cycle intact (only a
    reader told to tolerate that reports it). A dataclass: ``replay --json`` names its
    fields."""

    complete: bool
    cycles: int
    problem: str | None = None

    def describe(self) -> str:
        """One line for people: "complete", "index damaged, data intact" and why, or
        where and why the log was truncated."""
        if not self.complete:
            return f"truncated at cycle {self.cycles}: {self.problem}"
        return "complete" if self.problem is None else f"index damaged, data intact: {self.problem}"


class SessionLogReader(Closing):
    """Streams the cycles of one ``.beatlog`` file, in order, none missing or repeated;
    a context manager. The header is read and checked on opening; once iteration ends,
    :attr:`status` says whether the log was complete.

    Damage in the index after the cycles is a :class:`~beatlog.errors.CorruptLogError`
    even when every cycle and the end record read back intact, unless
    ``tolerate_damaged_index``: the status then says so. Given a
    :class:`~beatlog.log.recording.Recording`, the log is read once (its digest taken).
    """

    def __init__(self, path: LogSource, *, tolerate_damaged_index: bool = False) -> None:
        self.path = Path(path)
        self._tolerate_damaged_index = tolerate_damaged_index
        self._stream = RecordStream(path if isinstance(path, Recording) else self.path)
        self._channels: dict[int, Channel] = {}
        self._topics: dict[str, int] = {}
        self._schemas: dict[int, Schema] = {}
        self._cycles = 0
        self.robot_time_ns = 0
        """The robot time of the cycles read so far: the sum of their heartbeat intervals."""
        self.end: SessionEnd | None = None
        """The end record, once read: the recording closed cleanly."""
        self._status: LogStatus | None = None
        self._messages_read: Counter[int] = Counter()
        self._messages = self._topic_messages()
        try:
            self.header = self._read_header()
        except BaseException:
            self.close()
            raise
        self.format_version = self.header.format_version
        self._decoding = BatchDecoding(self.path, self.header)

    @property
    def status(self) -> LogStatus:
        """Whether the log closed cleanly; known once iteration has reached its end."""
        if self._status is None:
            raise RuntimeError("the log's status is known only after reading all its cycles")
        return self._status

    def batches(
        self, start: int = 0, skimmed: Callable[[list[CycleRecord]], object] | None = None
    ) -> Iterator[list[CycleRecord]]:
        """Yield the cycles in the batches they were written in, each checked, from cycle
        ``start`` on: the batch that holds it is cut there.

        The cycles before ``start`` are skimmed: checked as every batch is, but their
        parts (and a format-3 batch's columns) left undecoded, and handed to ``skimmed``
        a batch at a time instead of yielded. :attr:`robot_time_ns` counts them too.
        """
        for topic, message in self._messages:
            if topic == CYCLES_TOPIC:
                if self._cycles >= start:
                    yield self._batch(message)
                    continue
                first, time_ns = self._cycles, self.robot_time_ns
                batch = self._batch(message, skim=True)
                if self._cycles > start:  # it holds ``start``: read again, whole
                    self._cycles, self.robot_time_ns = first, time_ns
                    batch = self._batch(message)
                if skimmed is not None:
                    skimmed(batch[: start - first])
                if len(batch) > start - first:
                    yield batch[start - first :]
            elif topic == END_TOPIC:
                self._read_end(message)
            else:
                raise CorruptLogError(self.path, "a second session header")

    def decode_states(self, state_type: type[Any]) -> None:
        """Decode each cycle's RS_t into ``state_type`` from the next batch on, with its
        batch (format 3: the batch's :class:`~beatlog.log.columns.StateColumns`), and
        check its samples against the header: one that does not fit is a
        :class:`~beatlog.errors.SchemaMismatchError` (samples: damage) naming its cycle."""
        self._decoding.decode_states(state_type)

    def cycles(self) -> Iterator[CycleRecord]:
        """Yield every cycle in order."""
        for batch in self.batches():
            yield from batch

    def close(self) -> None:
        """Close the file."""
        self._stream.close()

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
        version = decoded_version(self.path, message.data)
        if version > FORMAT_VERSION:
            raise UnsupportedVersionError(
                self.path,
                f"written in format version {version}; this beatlog reads up to "
                f"{FORMAT_VERSION} (upgrade beatlog)",
            )
        header = decode_payload(self.path, message.data, SessionHeader, "session header")
        if (problem := header.problem()) is not None:
            raise CorruptLogError(self.path, f"damaged session header: {problem}")
        expected = schema_name(cycles_record(version))
        cycles = self._topics.get(CYCLES_TOPIC)
        found = None if cycles is None else self._schemas[self._channels[cycles].schema_id].name
        if found != expected:
            raise CorruptLogError(
                self.path,
                f"cycles have schema {found!r}, not the {expected!r} of format version {version}",
            )
        return header

    def _batch(self, message: Message, *, skim: bool = False) -> list[CycleRecord]:
        """Decode one cycles message and check it continues exactly where the last ended;
        skimmed, with its cycles' parts left undecoded (see :meth:`batches`)."""
        where = f"the batch after cycle {self._cycles}"
        decode = self._decoding.skim if skim else self._decoding.decode
        try:
            decoded = decode(message.data)
        except DECODE_ERRORS as exc:  # skimmed, its raw decoding fails as well: damage
            raise self._decoding.problem(message.data, where, self._cycles, exc) from None
        if isinstance(decoded, CycleBatch | ColumnBatch):
            if decoded.first_cycle != self._cycles:
                raise CorruptLogError(
                    self.path,
                    f"cycles out of order: a batch starts at cycle {decoded.first_cycle} "
                    f"where cycle {self._cycles} is next (a chunk missing, repeated or moved)",
                )
            batch = (
                decoded.cycles
                if skim or isinstance(decoded, CycleBatch)
                else self._decoding.records(decoded)
            )
        else:
            batch = decoded
        if not batch:
            raise CorruptLogError(self.path, f"{where} is empty")
        if message.log_time != self.robot_time_ns + batch[0].heartbeat_ns:
            raise CorruptLogError(
                self.path,
                f"cycles out of order: {where} is stamped {message.log_time} ns of robot "
                f"time, not {self.robot_time_ns + batch[0].heartbeat_ns} "
                "(a chunk missing, repeated or moved)",
            )
        self._cycles += len(batch)
        self.robot_time_ns += sum([cycle.heartbeat_ns for cycle in batch])
        return batch

    def _read_end(self, message: Message) -> None:
        end = decode_payload(self.path, message.data, SessionEnd, "end record")
        if message.log_time != end.robot_time_ns:
            raise CorruptLogError(
                self.path, "the end record is not stamped with the session's robot time"
            )
        if (end.cycles, end.robot_time_ns) != (self._cycles, self.robot_time_ns):
            raise CorruptLogError(
                self.path,
                f"the end record counts {end.cycles} cycles and {end.robot_time_ns} ns of "
                f"robot time, but the log holds {self._cycles} cycles and "
                f"{self.robot_time_ns} ns",
            )
        self.end = end

    def _topic_messages(self) -> Iterator[tuple[str, Message]]:
        """Messages with their channel's topic, in the order the format requires (the
        header, cycles, at most one end record); sets the status when the records end."""
        ended = False
        try:
            for record in self._stream.records():
                if isinstance(record, Message):
                    channel = self._channels.get(record.channel_id)
                    if channel is None:
                        raise CorruptLogError(
                            self.path, f"message on unknown channel {record.channel_id}"
                        )
                    if ended:
                        raise CorruptLogError(self.path, "a message after the end record")
                    self._messages_read[channel.id] += 1
                    ended = channel.topic == END_TOPIC
                    yield channel.topic, record
                elif isinstance(record, Schema):
                    self._add_schema(record)
                elif isinstance(record, Channel):
                    self._add_channel(record)
        except TruncatedError as cut:
            self._status = LogStatus(False, self._cycles, str(cut))
            self._stream.finish()
            return
        except IndexDamageError as damage:  # after intact cycles: tolerated, or an error
            if self.end is None:
                raise CorruptLogError(self.path, str(damage)) from None
            status = LogStatus(True, self._cycles, str(damage))
            if not self._tolerate_damaged_index:
                raise CorruptLogError(self.path, status.describe()) from None
            self._status = status
            return
        self._stream.check_summary(self._channels, self._schemas, self._messages_read)
        if self.end is None:
            self._status = LogStatus(False, self._cycles, "the log has no end record")
        else:
            self._status = LogStatus(True, self._cycles)

    def _defined_before(
        self, what: str, known: Schema | Channel | None, record: Schema | Channel
    ) -> bool:
        """Whether ``record`` (a ``what``) repeats ``known``, the one of its id met before;
        one that defines the id otherwise is damage."""
        if known is None:
            return False
        if known != record:
            raise CorruptLogError(self.path, f"{what} {record.id} is defined twice")
        return True

    def _add_schema(self, schema: Schema) -> None:
        if self._defined_before("schema", self._schemas.get(schema.id), schema):
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
        if self._defined_before("channel", self._channels.get(channel.id), channel):
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
