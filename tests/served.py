"""Session logs served over HTTP on the loopback, counting what each request sent: how
many times each log was downloaded, whatever process downloaded it."""

from __future__ import annotations

import collections
import contextlib
import functools
import http.server
import shutil
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO


@dataclass
class LogServer:
    """A folder served over HTTP; ``sent`` counts the bytes of file bodies sent per URL
    path (``/dock.beatlog``), HEAD requests sending none."""

    url: str
    folder: Path
    sent: collections.Counter[str] = field(default_factory=collections.Counter)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def downloads(self, name: str) -> float:
        """How many times the file ``name`` was sent whole (0.5: half of it once)."""
        with self.lock:
            return self.sent[f"/{name}"] / (self.folder / name).stat().st_size


@contextlib.contextmanager
def serve(folder: Path) -> Iterator[LogServer]:
    """Serve ``folder`` on a free loopback port for as long as the block runs."""
    server = LogServer("", folder)

    class Counting(http.server.SimpleHTTPRequestHandler):
        def copyfile(self, source: IO[bytes], outputfile: IO[bytes]) -> None:  # type: ignore[override]
            """Send a file's body, counting its bytes against its path."""
            before = source.tell()
            shutil.copyfileobj(source, outputfile)
            with server.lock:
                server.sent[self.path] += source.tell() - before

        def log_message(self, format: str, *args: object) -> None:
            """Serve without a line on stderr per request."""

    handler = functools.partial(Counting, directory=str(folder))
    with http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler) as httpd:
        thread = threading.Thread(target=httpd.serve_forever, daemon=True)
        thread.start()
        server.url = f"http://127.0.0.1:{httpd.server_address[1]}"
        try:
            yield server
        finally:
            httpd.shutdown()
            thread.join()
