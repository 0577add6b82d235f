"""Writes a session log from a background thread so the control loop never waits on disk.

The control thread encodes each cycle and queues it; the writer thread batches cycles
into messages and closes a chunk at least once per flush interval of robot time, so a
recorder killed mid-session leaves a log readable up to its last flush, and the same
session gives the same bytes on any machine. A write failure stops the writing, never
the robot (:attr:`SessionLogWriter.error`); a log whose header cannot be written is
removed: a recording leaves a valid log or nothing.
"""

from __future__ import annotations

import contextlib
import inspect
import os
import queue
import stat
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import IO, Any, Final

import msgspec
from mcap.writer import CompressionType, Writer

from beatlog.errors import LogError, LogExistsError
from beatlog.log.columns import column_batches
from beatlog.log.files import Closing
from beatlog.log.format import (
    COLUMNS_SINCE,
    CYCLES_TOPIC,
    END_TOPIC,
    HEADER_TOPIC,
    MESSAGE_ENCODING,
    PROFILE,
    SCHEMA_ENCODING,
    ColumnBatch,
    CycleBatch,
    SessionEnd,
    SessionHeader,
    payload_encoder,
    schema_name,
)
from beatlog.log.limits import MAX_SCHEMA_BYTES

__all__ = ["SessionLogWriter"]

_CLOSE: Final = object()
BATCH_BYTES = 1 << 20
"""A batch is written once its cycles reach this size, however few they are."""
MAX_CYCLE_BYTES = 4 << 20
"""The largest single cycle; a robot state is meant to be light."""


class SessionLogWriter(Closing):
    """Writes one session log; use it as a context manager or call :meth:`close`.

    :param overwrite: replace a log already at ``output``; without it an existing file
        is left untouched (recordings are immutable): :class:`~beatlog.errors.LogExistsError`.
    :param flush_interval_s: a chunk is closed and flushed at least this often, in robot
        time (the ``time_ns`` given to :meth:`append`).
    :param fsync: also fsync the file at each flush (survives power loss, costs I/O).
    :param batch_cycles: the most cycles put into one message.
    """

    def __init__(
        self,
        output: str | Path | IO[bytes],
        header: SessionHeader,
        *,
        overwrite: bool = False,
        flush_interval_s: float = 1.0,
        fsync: bool = False,
        batch_cycles: int = 256,
        chunk_size: int = 1 << 20,
    ) -> None:
        if flush_interval_s <= 0:
            raise ValueError(f"flush interval must be positive, got {flush_interval_s}")
        self.path = Path(output) if isinstance(output, str | Path) else None
        _check_header(header, self.path)
        self._file = self._open(output, overwrite=overwrite)
        self._fsync = fsync
        self._flush_interval_ns = int(flush_interval_s * 1e9)
        self._batch_cycles = batch_cycles
        self._encoder = payload_encoder()
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self.error: BaseException | None = None
        self.cycles_written = 0
        self.cycles_appended = 0
        """Cycles taken by :meth:`append` so far (written, or queued to be)."""
        self.robot_time_ns = 0
        """The sum of the heartbeat intervals of the cycles appended so far."""
        self._closed = False
        self._columns = header.format_version >= COLUMNS_SINCE
        self._state_fields = header.state_fields
        self._by_field = self._columns and bool(header.state_fields)
        """Whether each batch stores its robot states by field (those of a header that
        names their fields), not in its records."""
        self._mcap = Writer(self._file, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        try:
            self._start(header)
        except OSError as exc:
            if self.path is not None:
                self._discard(self.path)
            problem = f"cannot write: {exc.strerror or exc}"
            raise LogError(self.path or "<output>", problem) from None
        self._thread = threading.Thread(target=self._run, name="beatlog-writer", daemon=True)
        self._thread.start()

    def _start(self, header: SessionHeader) -> None:
        """Write the MCAP header, the channels and the session header, and flush them."""
        self._mcap.start(profile=PROFILE, library=f"beatlog {header.beatlog_version}")
        self._channels = {
            topic: self._mcap.register_channel(
                topic=topic,
                message_encoding=MESSAGE_ENCODING,
                schema_id=self._mcap.register_schema(
                    name=schema_name(struct),
                    encoding=SCHEMA_ENCODING,
                    data=record_schema(struct, described=not self._columns),
                ),
            )
            for topic, struct in (
                (HEADER_TOPIC, SessionHeader),
                (CYCLES_TOPIC, ColumnBatch if self._columns else CycleBatch),
                (END_TOPIC, SessionEnd),
            )
        }
        self._mcap.add_message(self._channels[HEADER_TOPIC], 0, self._encoder.encode(header), 0)
        self._flush()

    def _discard(self, path: Path) -> None:
        """Close a log file whose header could not be written, and remove it: no file
        without a header is left behind. A device written to (``/dev/full``) stays."""
        regular = stat.S_ISREG(os.fstat(self._file.fileno()).st_mode)
        with contextlib.suppress(OSError):  # its buffered bytes do not fit either
            self._file.close()
        if regular:
            with contextlib.suppress(OSError):
                path.unlink()

    @staticmethod
    def _open(output: str | Path | IO[bytes], *, overwrite: bool) -> IO[bytes]:
        if not isinstance(output, str | Path):
            return output
        try:
            return open(output, "wb" if overwrite else "xb")  # x: never replace a recording
        except FileExistsError:
            raise LogExistsError(output) from None
        except OSError as exc:
            raise LogError(output, f"cannot write: {exc.strerror}") from None

    def append(  # noqa: PLR0917 - positional on purpose: it runs every cycle
        self,
        hb_ns: int,
        state: msgspec.Struct | msgspec.Raw,
        changes: Sequence[Any],
        draws: Sequence[Any],
        outputs: dict[str, Any],
        samples: Sequence[Any] = (),
    ) -> None:
        """Queue one cycle, encoded now so later mutation of its parts cannot change it;
        ``state`` is RS_t, or its encoding as a :class:`msgspec.Raw` (the recorder's).
        Never blocks nor raises for an I/O problem: after a write failure the cycle is
        dropped and :attr:`error` says why."""
        if self.error is not None:
            return
        by_field = self._by_field
        # The fields of a CycleRecord, in order: an array of them is the record's bytes.
        entry = (hb_ns, None if by_field else state, changes, draws, outputs, samples)
        record = self._encoder.encode(entry)
        payload: Any = (record, self._encoder.encode(state)) if by_field else record
        size = len(record) + (len(payload[1]) if by_field else 0)
        if size > MAX_CYCLE_BYTES:
            self.error = LogError(
                self.path or "<output>",
                f"cycle {self.cycles_appended} is {size} bytes; the most a cycle may "
                f"hold is {MAX_CYCLE_BYTES} (keep the robot state light)",
            )
            return
        self.cycles_appended += 1
        self.robot_time_ns += hb_ns
        self._queue.put((self.robot_time_ns, payload, size))

    def close(self, end: SessionEnd | None = None) -> None:
        """Write what is queued and the end record, then finish and close the file."""
        if self._closed:
            return
        self._closed = True
        self._queue.put((_CLOSE, end))
        self._thread.join()
        if self.path is not None:
            self._file.close()

    def _run(self) -> None:
        """Batch cycles, and close a chunk whenever a flush interval of robot time passed:
        never by the wall clock, so the same session gives the same bytes."""
        pending: list[tuple[int, Any, int]] = []
        pending_bytes = 0
        flush_at: int | None = None
        while True:
            item = self._queue.get()
            if item[0] is _CLOSE:
                break
            time_ns, _, size = item
            pending.append(item)
            pending_bytes += size
            if flush_at is None:
                flush_at = time_ns + self._flush_interval_ns
            due = time_ns >= flush_at
            if due or len(pending) >= self._batch_cycles or pending_bytes >= BATCH_BYTES:
                self._guard(self._write_batch, pending)
                pending_bytes = 0
            if due:
                self._guard(self._flush)
                flush_at = time_ns + self._flush_interval_ns
        self._guard(self._write_batch, pending)
        self._guard(self._finish, item[1])

    def _guard(self, write: Any, *args: Any) -> None:
        if self.error is not None:
            return
        try:
            write(*args)
        except Exception as exc:
            self.error = exc

    def _write_batch(self, pending: list[tuple[int, Any, int]]) -> None:
        if not pending:
            return
        if self._by_field:
            records, states = zip(*[payload for _, payload, _ in pending], strict=True)
            batches = column_batches(self.cycles_written, records, states, self._state_fields)
            messages = [(pending[start][0], self._encoder.encode(b)) for start, b in batches]
        else:  # records that hold their robot states: the same bytes in formats 2 and 3
            cycles = [msgspec.Raw(payload) for _, payload, _ in pending]
            messages = [(pending[0][0], self._encoder.encode((self.cycles_written, cycles)))]
        for first_ns, message in messages:
            self._mcap.add_message(self._channels[CYCLES_TOPIC], first_ns, message, first_ns)
        self.cycles_written += len(pending)
        pending.clear()

    def _flush(self) -> None:
        self._mcap.flush()  # type: ignore[no-untyped-call]
        if self._fsync:
            os.fsync(self._file.fileno())

    def _finish(self, end: SessionEnd | None) -> None:
        if end is not None:
            at = end.robot_time_ns
            self._mcap.add_message(self._channels[END_TOPIC], at, self._encoder.encode(end), at)
        self._mcap.finish()  # type: ignore[no-untyped-call]
        self._file.flush()
        if self._fsync:
            os.fsync(self._file.fileno())


def record_schema(record: type[msgspec.Struct], *, described: bool) -> bytes:
    """The JSON schema of a record type as a log embeds it: from format 3 on, its layout
    without the descriptions (``docs/format.md`` says what each field means), which
    every log would otherwise carry twice; before, with them, each docstring cleaned as
    :func:`inspect.cleandoc` cleans it, so that the bytes do not depend on the msgspec
    that made the schema (0.23 cleans docstrings itself, earlier ones did not)."""
    return msgspec.json.encode(_descriptions(msgspec.json.schema(record), kept=described))


def _descriptions(node: Any, *, kept: bool) -> Any:
    """A JSON schema with its descriptions cleaned (``kept``) or left out."""
    if isinstance(node, dict):
        return {
            key: inspect.cleandoc(value)
            if key == "description" and isinstance(value, str)
            else _descriptions(value, kept=kept)
            for key, value in node.items()
            if kept or key != "description" or not isinstance(value, str)
        }
    if isinstance(node, list):
        return [_descriptions(value, kept=kept) for value in node]
    return node


def _check_header(header: SessionHeader, path: Path | None) -> None:
    """Refuse a header that readers would refuse, so every recording can be read back."""
    where = path or "<output>"
    encoded = payload_encoder().encode(header)
    if len(encoded) > MAX_SCHEMA_BYTES:
        raise LogError(where, f"cannot record: the session header is {len(encoded)} bytes")
    try:
        msgspec.msgpack.decode(encoded, type=SessionHeader)
    except msgspec.ValidationError as exc:
        raise LogError(where, f"cannot record: session header: {exc}") from None
    if (problem := header.problem()) is not None:
        raise LogError(where, f"cannot record: {problem}")
