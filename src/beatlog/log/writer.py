"""Writes a session log from a background thread so the control loop never waits on disk.

The control thread encodes each cycle into immutable bytes (a few microseconds) and
queues them. The writer thread batches cycles into messages and closes an MCAP chunk
at least once per flush interval, so a recorder killed mid-session leaves a log that
is readable up to its last flushed cycle. A write failure stops the writing, never
the robot: it is kept in :attr:`SessionLogWriter.error` and the log stays valid up
to the failure.
"""

from __future__ import annotations

import contextlib
import os
import queue
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import IO, Any, Final

import msgspec
from mcap.writer import CompressionType, Writer

from beatlog.errors import LogError
from beatlog.log.format import (
    CYCLES_TOPIC,
    END_TOPIC,
    HEADER_TOPIC,
    MESSAGE_ENCODING,
    PROFILE,
    CycleRecord,
    SessionEnd,
    SessionHeader,
    payload_encoder,
)

__all__ = ["SessionLogWriter"]

_CLOSE: Final = object()


class SessionLogWriter:
    """Writes one session log; use it as a context manager or call :meth:`close`.

    :param flush_interval_s: a chunk is closed and flushed at least this often.
    :param fsync: also fsync the file at each flush (survives power loss, costs I/O).
    :param batch_cycles: the most cycles put into one message.
    """

    def __init__(
        self,
        output: str | Path | IO[bytes],
        header: SessionHeader,
        *,
        flush_interval_s: float = 1.0,
        fsync: bool = False,
        batch_cycles: int = 256,
        chunk_size: int = 1 << 20,
    ) -> None:
        if flush_interval_s <= 0:
            raise ValueError(f"flush interval must be positive, got {flush_interval_s}")
        self.path = Path(output) if isinstance(output, str | Path) else None
        self._file = self._open(output)
        self._fsync = fsync
        self._flush_interval_ns = int(flush_interval_s * 1e9)
        self._batch_cycles = batch_cycles
        self._encoder = payload_encoder()
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self.error: BaseException | None = None
        self.cycles_written = 0
        self._closed = False

        self._mcap = Writer(self._file, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        try:
            self._start(header)
        except OSError as exc:
            if self.path is not None:
                with contextlib.suppress(OSError):
                    self._file.close()
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
                    name=f"beatlog.{struct.__name__}",
                    encoding="jsonschema",
                    data=msgspec.json.encode(msgspec.json.schema(struct)),
                ),
            )
            for topic, struct in (
                (HEADER_TOPIC, SessionHeader),
                (CYCLES_TOPIC, CycleRecord),
                (END_TOPIC, SessionEnd),
            )
        }
        self._mcap.add_message(self._channels[HEADER_TOPIC], 0, self._encoder.encode(header), 0)
        self._flush()

    @staticmethod
    def _open(output: str | Path | IO[bytes]) -> IO[bytes]:
        if not isinstance(output, str | Path):
            return output
        try:
            return open(output, "wb")
        except OSError as exc:
            raise LogError(output, f"cannot write: {exc.strerror}") from None

    def append(  # noqa: PLR0917 - positional on purpose: it runs every cycle
        self,
        time_ns: int,
        hb_ns: int,
        state: msgspec.Struct,
        changes: Sequence[Any],
        draws: Sequence[Any],
        outputs: dict[str, Any],
        samples: Sequence[Any] = (),
    ) -> None:
        """Queue one cycle, encoded now so later mutation of its parts cannot change it.

        Never blocks and never raises for an I/O problem; after a write failure the
        cycle is dropped and :attr:`error` says why.
        """
        if self.error is not None:
            return
        payload = self._encoder.encode((hb_ns, state, changes, draws, outputs, samples))
        self._queue.put((time_ns, payload))

    def close(self, end: SessionEnd | None = None) -> None:
        """Write what is queued and the end record, then finish and close the file."""
        if self._closed:
            return
        self._closed = True
        self._queue.put((_CLOSE, end))
        self._thread.join()
        if self.path is not None:
            self._file.close()

    def __enter__(self) -> SessionLogWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _run(self) -> None:
        pending: list[tuple[int, bytes]] = []
        deadline = time.monotonic_ns() + self._flush_interval_ns
        end: SessionEnd | None = None
        while True:
            timeout = max(deadline - time.monotonic_ns(), 0) / 1e9
            try:
                item = self._queue.get(timeout=timeout)
            except queue.Empty:
                item = None
            if item is not None and item[0] is _CLOSE:
                end = item[1]
                break
            if item is not None:
                pending.append(item)
                if len(pending) >= self._batch_cycles:
                    self._guard(self._write_batch, pending)
            if time.monotonic_ns() >= deadline:
                self._guard(self._write_batch, pending)
                self._guard(self._flush)
                deadline = time.monotonic_ns() + self._flush_interval_ns
        self._guard(self._write_batch, pending)
        self._guard(self._finish, end)

    def _guard(self, write: Any, *args: Any) -> None:
        if self.error is not None:
            return
        try:
            write(*args)
        except Exception as exc:
            self.error = exc

    def _write_batch(self, pending: list[tuple[int, bytes]]) -> None:
        if not pending:
            return
        batch = self._encoder.encode([msgspec.Raw(payload) for _, payload in pending])
        first_ns = pending[0][0]
        self._mcap.add_message(self._channels[CYCLES_TOPIC], first_ns, batch, first_ns)
        self.cycles_written += len(pending)
        pending.clear()

    def _flush(self) -> None:
        self._mcap.flush()  # type: ignore[no-untyped-call]
        if self._fsync:
            os.fsync(self._file.fileno())

    def _finish(self, end: SessionEnd | None) -> None:
        if end is not None:
            self._mcap.add_message(
                self._channels[END_TOPIC],
                end.robot_time_ns,
                self._encoder.encode(end),
                end.robot_time_ns,
            )
        self._mcap.finish()  # type: ignore[no-untyped-call]
        self._file.flush()
        if self._fsync:
            os.fsync(self._file.fileno())
