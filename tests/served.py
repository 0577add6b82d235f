"""Session logs served over HTTP on the loopback, counting what each request sent: how
many times each log was downloaded, whatever process downloaded it.

The first folder of a path may also name a way to misbehave (``/cut-length/dock.beatlog``
sends half of ``dock.beatlog``, then hangs up): see :data:`MISBEHAVIOURS`.
"""

from __future__ import annotations

import collections
import contextlib
import functools
import http.server
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

TRICKLE_S = 0.2
"""How often the ``trickle`` server sends its next byte."""
_ENDLESS_BLOCK = b"\0" * (64 << 10)


@dataclass
class LogServer:
    """A folder served over HTTP; ``sent`` counts the bytes of file bodies sent per URL
    path (``/dock.beatlog``), HEAD requests sending none, and ``requests`` the requests
    answered, by method and path (``GET /dock.beatlog``)."""

    url: str
    folder: Path
    sent: collections.Counter[str] = field(default_factory=collections.Counter)
    requests: collections.Counter[str] = field(default_factory=collections.Counter)
    lock: threading.Lock = field(default_factory=threading.Lock)
    stopping: threading.Event = field(default_factory=threading.Event)
    gate: threading.Event = field(default_factory=threading.Event)
    """Opened, it lets the ``gated`` downloads send their bodies."""

    def downloads(self, name: str) -> float:
        """How many times the file ``name`` was sent whole (0.5: half of it once)."""
        with self.lock:
            return self.sent[f"/{name}"] / (self.folder / name).stat().st_size


COPY_BLOCK = 64 * 1024
"""How much of a file's body the server sends at a time."""


class _Misbehaving(http.server.SimpleHTTPRequestHandler):
    """Answers a path whose first folder names a misbehaviour as it says; HEAD requests
    get the headers a GET would."""

    server_state: LogServer

    def send_head(self) -> IO[bytes] | None:  # type: ignore[override]
        """Misbehave where the path asks for it; otherwise serve the file."""
        with self.server_state.lock:
            self.server_state.requests[f"{self.command} {self.path}"] += 1
        way, _, name = self.path.lstrip("/").partition("/")
        misbehaviour = MISBEHAVIOURS.get(way)
        if misbehaviour is None:
            return super().send_head()
        body = self.server_state.folder / name
        with contextlib.suppress(OSError):  # the client hung up
            misbehaviour(self, body.read_bytes() if body.is_file() else b"")
        return None

    def headers_for(self, length: int | None, *, chunked: bool = False) -> bool:
        """Send a 200 with ``Content-Length: length`` (none if None), or a chunked one;
        whether a body is to follow (not after a HEAD)."""
        if chunked:
            self.protocol_version = "HTTP/1.1"
        self.send_response(200)
        self.send_header("Content-Type", "application/octet-stream")
        if length is not None:
            self.send_header("Content-Length", str(length))
        if chunked:
            self.send_header("Transfer-Encoding", "chunked")
        self.send_header("Connection", "close")
        self.end_headers()
        self.close_connection = True
        return self.command == "GET"

    def send_chunk(self, data: bytes) -> None:
        """One chunk of a chunked body (an empty one ends it)."""
        self.wfile.write(b"%x\r\n%s\r\n" % (len(data), data))
        self.wfile.flush()

    def stall(self, log: bytes) -> None:
        """Promise the log, then send nothing until the server stops."""
        if self.headers_for(len(log)):
            self.wfile.flush()
            self.server_state.stopping.wait()

    def gated(self, log: bytes) -> None:
        """Promise the log, then send it once the server's gate opens."""
        if self.headers_for(len(log)):
            self.wfile.flush()
            self.server_state.gate.wait()
            self.wfile.write(log)

    def trickle(self, log: bytes) -> None:
        """A chunked body sent a byte at a time, never ending while the client reads."""
        if self.headers_for(None, chunked=True):
            while not self.server_state.stopping.wait(TRICKLE_S):
                self.send_chunk(b"\0")

    def endless(self, log: bytes) -> None:
        """A chunked body that never ends, 64 KiB a millisecond at most (no test needs
        gigabytes on disk)."""
        if self.headers_for(None, chunked=True):
            while not self.server_state.stopping.wait(0.001):
                self.send_chunk(_ENDLESS_BLOCK)

    def cut_length(self, log: bytes) -> None:
        """Promise the log's length, send half of it, hang up."""
        if self.headers_for(len(log)):
            self.wfile.write(log[: len(log) // 2])

    def cut_close(self, log: bytes) -> None:
        """No length (the body ends when the connection does): half the log, hang up."""
        if self.headers_for(None):
            self.wfile.write(log[: len(log) // 2])

    def cut_listed(self, log: bytes) -> None:
        """Tell a HEAD the log's length; to a GET send half of it with none, hang up."""
        if self.headers_for(len(log) if self.command == "HEAD" else None):
            self.wfile.write(log[: len(log) // 2])

    def cut_chunked(self, log: bytes) -> None:
        """Half the log in chunks, then hang up without the last, empty chunk."""
        if self.headers_for(None, chunked=True):
            self.send_chunk(log[: len(log) // 4])
            self.send_chunk(log[len(log) // 4 : len(log) // 2])

    def chunked(self, log: bytes) -> None:
        """The whole log in chunks, ended as HTTP/1.1 ends a chunked body."""
        if self.headers_for(None, chunked=True):
            self.send_chunk(log[: len(log) // 2])
            self.send_chunk(log[len(log) // 2 :])
            self.send_chunk(b"")

    def closing(self, log: bytes) -> None:
        """The whole log without a length: the body ends when the connection does."""
        if self.headers_for(None):
            self.wfile.write(log)


MISBEHAVIOURS: dict[str, Callable[[_Misbehaving, bytes], None]] = {
    "stall": _Misbehaving.stall,
    "gated": _Misbehaving.gated,
    "trickle": _Misbehaving.trickle,
    "endless": _Misbehaving.endless,
    "cut-length": _Misbehaving.cut_length,
    "cut-close": _Misbehaving.cut_close,
    "cut-listed": _Misbehaving.cut_listed,
    "cut-chunked": _Misbehaving.cut_chunked,
    "chunked": _Misbehaving.chunked,
    "close": _Misbehaving.closing,
}
"""The ways a path's first folder may ask the server to misbehave, given the bytes of
the file the rest of the path names (empty if none)."""


@contextlib.contextmanager
def serve(folder: Path) -> Iterator[LogServer]:
    """Serve ``folder`` on a free loopback port for as long as the block runs."""
    server = LogServer("", folder)

    class Counting(_Misbehaving):
        server_state = server

        def copyfile(self, source: IO[bytes], outputfile: IO[bytes]) -> None:  # type: ignore[override]
            """Send a file's body, counting its bytes against its path before they go,
            so a client that has read them all finds them counted."""
            while block := source.read(COPY_BLOCK):
                with server.lock:
                    server.sent[self.path] += len(block)
                outputfile.write(block)

        def log_message(self, format: str, *args: object) -> None:
            """Serve without a line on stderr per request."""

    handler = functools.partial(Counting, directory=str(folder))
    with http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler) as httpd:
        thread = threading.Thread(target=httpd.serve_forever, args=(0.05,), daemon=True)
        thread.start()
        server.url = f"http://127.0.0.1:{httpd.server_address[1]}"
        try:
            yield server
        finally:
            server.stopping.set()
            server.gate.set()
            httpd.shutdown()
            thread.join()
