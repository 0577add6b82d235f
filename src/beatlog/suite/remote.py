"""Session logs behind URLs: any URL fsspec reads (``https://``, ``s3://``, ``gs://``,
``memory://``), where fsspec is installed (``pip install "beatlog[fleet]"``).

The reader needs a regular, seekable file, so the process that reads a log behind a
URL copies it whole onto its own machine first (:func:`fetched_log`), and removes the
copy when done, interrupted or not. The copy is kept in the machine's cache of logs
(:mod:`beatlog.suite.log_cache`), which a cluster's worker fills ahead
(:func:`fetch_ahead`). A log a listing found comes with its size and ETag
(:class:`Listed`): its download is then one request, and a copy in the cache none.

A download is bounded: ``BEATLOG_URL_MAX_BYTES`` bytes at most (:data:`MAX_LOG_BYTES`
unless set). Over ``http(s)`` a server must connect, send each next bytes, and answer a
size or a listing whole within ``BEATLOG_URL_TIMEOUT`` seconds (:data:`TIMEOUT_S` unless
set); once a download of any scheme has run that long it must average
:data:`MIN_RATE` bytes a second. A download that does not end cleanly (cut off, a size
other than the one listed, or a body whose end the server does not say) is an error:
no partial copy reaches the reader.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path, PurePosixPath
from typing import Any, NamedTuple, TypeVar
from urllib.parse import quote, unquote, urlsplit, urlunsplit

from beatlog.errors import RemoteLogError, first_line
from beatlog.suite.log_cache import cached_copy, holds

__all__ = [
    "MAX_BYTES_VARIABLE",
    "MAX_LOG_BYTES",
    "MIN_RATE",
    "PROGRESS_BYTES",
    "TIMEOUT_S",
    "TIMEOUT_VARIABLE",
    "Listed",
    "fetch_ahead",
    "fetched_log",
    "http_quoted",
    "is_url",
    "log_size",
    "url_filesystem",
    "url_name",
    "wait_for",
]

MAX_LOG_BYTES = 256 << 20
"""The largest log copied from a URL, unless ``BEATLOG_URL_MAX_BYTES`` says otherwise:
about two days of the reference dog's recording."""
MAX_BYTES_VARIABLE = "BEATLOG_URL_MAX_BYTES"
TIMEOUT_S = 30.0
"""How long a server may keep a download waiting, unless ``BEATLOG_URL_TIMEOUT`` says
otherwise (in seconds)."""
TIMEOUT_VARIABLE = "BEATLOG_URL_TIMEOUT"
MIN_RATE = 64 << 10
"""Bytes a second a download must average once it has run longer than its timeout."""
PROGRESS_BYTES = 8 << 20
"""Bytes downloaded after which a download shows its progress, where it may."""
Number = TypeVar("Number", int, float)
_URL = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*://")
_BLOCK = 1 << 20
_HTTP = ("http", "https")
_fetching_lock = threading.Lock()
_fetching: dict[str, threading.Thread] = {}
"""The logs this process fetches ahead, by URL."""


class Listed(NamedTuple):
    """What the listing that found a log behind a URL said of it."""

    size: int
    """Its size in bytes."""
    etag: str
    """Its ETag, which changes whenever the object does."""

    def info(self) -> dict[str, Any]:
        """What was listed, as fsspec's ``info()`` says it."""
        return {"size": self.size, "ETag": self.etag}


def is_url(text: str) -> bool:
    """Whether a log's path, pattern or source is a URL (``s3://...``) rather than a
    local path."""
    return _URL.match(text) is not None


def url_name(url: str) -> str:
    """The file name at the end of ``url``'s path (``walk.beatlog``); for ``http(s)``
    with its percent-escapes decoded (``with%20space.beatlog`` is ``with space.beatlog``,
    as the server names the file), unless decoding would make it no plain file name."""
    split = urlsplit(url)
    name = PurePosixPath(split.path).name or "log.beatlog"
    if split.scheme in _HTTP:
        decoded = unquote(name)
        if decoded not in (".", "..") and not {"/", "\0"} & set(decoded):
            return decoded
    return name


def http_quoted(url: str) -> str:
    """``url`` with the characters an ``http(s)`` path cannot hold percent-escaped
    (``with space*.beatlog`` as ``with%20space*.beatlog``); glob characters and escapes
    already written stay. Other URLs are returned as they are."""
    split = urlsplit(url)
    if split.scheme not in _HTTP:
        return url
    return urlunsplit(split._replace(path=quote(split.path, safe="/%*?[]!:@&=+$,;~")))


def url_filesystem(url: str, *, streaming: bool = False) -> tuple[Any, str]:
    """The fsspec filesystem behind ``url``, and the URL's path on it; over ``http(s)``
    each request but a download (``streaming``) ends within ``BEATLOG_URL_TIMEOUT``.

    :raises RemoteLogError: fsspec, or the URL's backend, is not installed, the scheme
        is unknown, or ``BEATLOG_URL_TIMEOUT`` holds no number.
    """
    try:
        from fsspec.core import url_to_fs  # noqa: PLC0415 - an optional dependency
    except ModuleNotFoundError:
        raise RemoteLogError(url, 'a URL needs fsspec (pip install "beatlog[fleet]")') from None
    scheme = urlsplit(url).scheme
    try:
        options: dict[str, Any] = {}
        if scheme in _HTTP:
            from aiohttp import ClientTimeout  # noqa: PLC0415 - fsspec's HTTP dependency
            from fsspec.config import conf  # noqa: PLC0415 - an optional dependency

            configured = conf.get(scheme, {}).get("client_kwargs", {})
            timeout = _timeout(url)
            waited = ClientTimeout(  # connect, and send the next bytes, within the timeout
                total=None if streaming else timeout,
                connect=timeout,
                sock_connect=timeout,
                sock_read=timeout,
            )
            options["client_kwargs"] = {**configured, "timeout": waited}
        if scheme in ("s3", "s3a"):
            options["local_expiry_check"] = True  # a download's ETag checked against ours
        filesystem, path = url_to_fs(url, **options)
    except (ImportError, ValueError) as exc:  # ImportError: a backend's package
        raise RemoteLogError(url, f"cannot open: {exc}") from None
    return filesystem, path


@contextlib.contextmanager
def fetched_log(
    url: str, *, progress: bool = False, listed: Listed | None = None
) -> Iterator[Path]:
    """A copy of the log behind ``url`` on this machine, under the URL's file name,
    removed on exit, Ctrl-C included; the cache's where it holds the object as it is.
    With ``progress``, a long download shows a bar on a terminal's stderr; with
    ``listed``, the storage is asked nothing but the download, and nothing where the
    cache holds that ETag.

    :raises RemoteLogError: the URL needs fsspec, or the log cannot be copied (missing,
        unreachable, too slow, cut off, too large), or a bound's variable is no number.
    """
    max_bytes = _bound(url, MAX_BYTES_VARIABLE, MAX_LOG_BYTES, int, "a number of bytes")
    timeout = _timeout(url)
    if listed is None:
        filesystem, path = url_filesystem(url, streaming=True)
        with _answering(url, "cannot copy"):
            info: dict[str, Any] = filesystem.info(path)
    else:
        info = listed.info()
    size: int | None = info.get("size")
    too_big = (
        f"larger than the {max_bytes} bytes a log behind a URL may have ({MAX_BYTES_VARIABLE})"
    )

    def fetch(copy: Path) -> None:
        """Copy the log whole within the bounds, or raise. Opened with its size, where
        known, it asks the storage nothing first; with its ETag, a download of an object
        changed since is refused by the backends that check it (s3fs, told to). The
        storage's filesystem is opened only here: a listed log in the cache needs none
        (nor its package's imports, s3fs's a second of CPU)."""
        from fsspec.spec import AbstractBufferedFile  # noqa: PLC0415 - an optional dependency

        filesystem, path = url_filesystem(url, streaming=True)
        if size is not None and size > max_bytes:
            raise RemoteLogError(url, too_big)
        # Over HTTP a stream (block_size=0): a server need not serve the byte ranges that
        # fsspec's random-access HTTP file asks for (Python's own http.server does not).
        protocols = filesystem.protocol
        streamed = set(_HTTP) & set((protocols,) if isinstance(protocols, str) else protocols)
        opened = ({"block_size": 0} if streamed else {}) | ({} if size is None else {"size": size})
        started, copied = time.monotonic(), 0
        with (
            _progress_bar(url_name(url), shown=progress) as meter,
            _answering(url, "cannot copy"),
            filesystem.open(path, "rb", **opened) as source,
            copy.open("wb") as target,
        ):
            if isinstance(source, AbstractBufferedFile):  # asks for these before reading
                source.details = {"name": path, **info}  # unless told
            response = getattr(source, "r", None)  # fsspec's HTTP stream: aiohttp's response
            if (
                size is None
                and response is not None
                and response.content_length is None
                and "chunked" not in response.headers.get("Transfer-Encoding", "").lower()
            ):
                raise RemoteLogError(
                    url,
                    "the server sent neither its length nor a chunked body: "
                    "a download cut off could not be told from the whole log",
                )
            while block := source.read(_BLOCK):
                copied += len(block)
                if copied > max_bytes:  # a size the listing got wrong, or none
                    raise RemoteLogError(url, too_big)
                if time.monotonic() - started > timeout + copied / MIN_RATE:
                    raise RemoteLogError(
                        url,
                        f"too slow: a download must average {MIN_RATE >> 10} KiB/s past "
                        f"its first {timeout:g} s ({TIMEOUT_VARIABLE})",
                    )
                target.write(block)
                meter(copied, size)
        if size is not None and copied != size:
            raise RemoteLogError(url, f"download cut off or changed: {copied} of its {size} bytes")

    with cached_copy(url, info, url_name(url), fetch) as copy:
        yield copy


def log_size(url: str) -> int | None:
    """The size in bytes of the log behind ``url`` as its filesystem lists it, nothing of
    the log read; None where it does not say (else :class:`RemoteLogError`)."""
    filesystem, path = url_filesystem(url)
    with _answering(url, "cannot read its size"):
        size = filesystem.size(path)
    return None if size is None else int(size)


def fetch_ahead(url: str, listed: Listed | None = None) -> None:
    """Start copying the log behind ``url`` (which a listing described as ``listed``, if
    given) into this machine's cache in the background, unless the cache has it, as the
    listing described it, or this process is already at it (:func:`wait_for` waits for
    it), so that fetching overlaps replaying. A log that cannot be fetched is left to
    the DTC's own copy, which says what is wrong."""
    if listed is not None and holds(url, listed.info()):
        return

    def fetch() -> None:
        try:
            with fetched_log(url, listed=listed):
                pass
        except RemoteLogError:
            pass  # the DTC's own copy says what is wrong
        finally:
            with _fetching_lock:
                del _fetching[url]

    with _fetching_lock:
        if url not in _fetching:
            _fetching[url] = threading.Thread(target=fetch, name="beatlog-fetch", daemon=True)
            _fetching[url].start()


def wait_for(url: str) -> None:
    """Return once this process is no longer fetching ``url`` ahead."""
    with _fetching_lock:
        thread = _fetching.get(url)
    if thread is not None:
        thread.join()


@contextlib.contextmanager
def _answering(url: str, doing: str) -> Iterator[None]:
    """Turn what the storage of ``url`` raises in the block into one line.

    :raises RemoteLogError: the log is missing or unreachable, or the block raised one.
    """
    try:
        yield
    except RemoteLogError:
        raise
    except FileNotFoundError as exc:
        cause = exc.__cause__  # fsspec's HTTP says so of a server it cannot reach
        if (
            cause is None
            or isinstance(cause, FileNotFoundError)
            or getattr(cause, "status", 0) == 404
        ):
            raise RemoteLogError(url, "no such log") from None
        raise _failed(url, cause, doing) from None
    except Exception as exc:  # backends' errors (aiohttp, botocore) share no base
        raise _failed(url, exc, doing) from None


def _timeout(url: str) -> float:
    """How long a server may keep a download of ``url`` waiting, in seconds."""
    return _bound(url, TIMEOUT_VARIABLE, TIMEOUT_S, float, "a number of seconds")


def _bound(url: str, variable: str, default: Number, kind: type[Number], what: str) -> Number:
    """A bound from the environment variable ``variable``, ``default`` where unset; a
    :class:`RemoteLogError` where it is set to no such number above 0."""
    text = os.environ.get(variable, "").strip()
    if not text:
        return default
    try:
        value = kind(text)
    except ValueError:
        value = None
    if value is None or not 0 < value < math.inf:
        raise RemoteLogError(url, f"{variable}={text}: not {what} above 0")
    return value


@contextlib.contextmanager
def _progress_bar(name: str, *, shown: bool) -> Iterator[Callable[[int, int | None], None]]:
    """A function to tell the bytes copied so far and the size (None if not known),
    which shows a bar naming ``name`` on stderr once :data:`PROGRESS_BYTES` have come,
    where ``shown`` and stderr is a terminal; the bar is gone when the block ends."""
    if not shown or not sys.stderr.isatty():
        yield lambda copied, size: None
        return
    from rich.console import Console  # noqa: PLC0415 - only for a big download
    from rich.progress import (  # noqa: PLC0415
        BarColumn,
        DownloadColumn,
        Progress,
        TextColumn,
        TimeRemainingColumn,
        TransferSpeedColumn,
    )

    bar = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        DownloadColumn(),
        TransferSpeedColumn(),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        transient=True,
    )

    def meter(copied: int, size: int | None) -> None:
        if not bar.tasks:
            if copied < PROGRESS_BYTES:
                return
            bar.start()
            bar.add_task(name, total=size)
        bar.update(bar.task_ids[0], completed=copied)

    try:
        yield meter
    finally:
        bar.stop()


def _failed(url: str, exc: BaseException, doing: str) -> RemoteLogError:
    """A backend's error as one line; an HTTP timeout names its bound."""
    if isinstance(exc, TimeoutError) and urlsplit(url).scheme in _HTTP:  # aiohttp's
        return RemoteLogError(
            url, f"{doing}: no answer for {_timeout(url):g} s ({TIMEOUT_VARIABLE})"
        )
    return RemoteLogError(url, f"{doing}: {first_line(exc)}")
