"""Session logs behind URLs: any URL fsspec reads (``https://``, ``s3://``, ``gs://``,
``memory://``), where fsspec is installed (``pip install "beatlog[fleet]"``).

The reader needs a regular, seekable file, so the process that reads a log behind a
URL copies it whole into a temporary folder of its own machine first, up to a bound
(:func:`fetched_log`), and removes the copy when done; nothing else downloads it.
Planning work (splitting a suite into shards) asks only for its size (:func:`log_size`).
"""

from __future__ import annotations

import contextlib
import re
import tempfile
from collections.abc import Iterator
from pathlib import Path, PurePosixPath
from typing import Any
from urllib.parse import quote, unquote, urlsplit, urlunsplit

from beatlog.errors import RemoteLogError, first_line

__all__ = [
    "MAX_LOG_BYTES",
    "fetched_log",
    "http_quoted",
    "is_url",
    "log_size",
    "named_as_given",
    "url_filesystem",
    "url_name",
]

MAX_LOG_BYTES = 4 << 30
"""The largest log copied from a URL: far more than hours of recording."""
_URL = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*://")
_BLOCK = 1 << 20


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
    if split.scheme in ("http", "https"):
        decoded = unquote(name)
        if decoded not in (".", "..") and not {"/", "\0"} & set(decoded):
            return decoded
    return name


def http_quoted(url: str) -> str:
    """``url`` with the characters an ``http(s)`` path cannot hold percent-escaped
    (``with space*.beatlog`` as ``with%20space*.beatlog``); glob characters and escapes
    already written stay. Other URLs are returned as they are."""
    split = urlsplit(url)
    if split.scheme not in ("http", "https"):
        return url
    return urlunsplit(split._replace(path=quote(split.path, safe="/%*?[]!:@&=+$,;~")))


def url_filesystem(url: str) -> tuple[Any, str]:
    """The fsspec filesystem behind ``url``, and the URL's path on it.

    :raises RemoteLogError: fsspec is not installed, or knows no such URL (an unknown
        scheme, or one whose backend's package is missing).
    """
    try:
        from fsspec.core import url_to_fs  # noqa: PLC0415 - an optional dependency
    except ModuleNotFoundError:
        raise RemoteLogError(url, 'a URL needs fsspec (pip install "beatlog[fleet]")') from None
    try:
        filesystem, path = url_to_fs(url)
    except (ImportError, ValueError) as exc:  # ImportError: a backend's package
        raise RemoteLogError(url, f"cannot open: {exc}") from None
    return filesystem, path


@contextlib.contextmanager
def fetched_log(url: str, max_bytes: int = MAX_LOG_BYTES) -> Iterator[Path]:
    """A copy of the log behind ``url`` in a temporary folder of this machine, under the
    URL's file name, removed on exit.

    :raises RemoteLogError: the URL needs fsspec, or the log cannot be copied (missing,
        unreachable) or is larger than ``max_bytes``.
    """
    filesystem, path = url_filesystem(url)
    with tempfile.TemporaryDirectory(prefix="beatlog-remote-") as folder:
        copy = Path(folder, url_name(url))
        _copy(filesystem, path, copy, url, max_bytes)
        yield copy


def named_as_given(text: str, copy: str | Path, url: str) -> str:
    """``text`` (a message, a command) with the copy of a log behind ``url``, which
    :func:`fetched_log` made and removes, named by the URL instead."""
    return text.replace(str(copy), url)


def log_size(url: str) -> int | None:
    """The size in bytes of the log behind ``url``, as its filesystem lists it (an HTTP
    ``HEAD``, an object's metadata): nothing of the log is read. None where the
    filesystem does not say.

    :raises RemoteLogError: the URL needs fsspec, or the log is missing or unreachable.
    """
    filesystem, path = url_filesystem(url)
    try:
        size = filesystem.size(path)
    except FileNotFoundError as exc:
        raise _not_found(url, exc, "cannot read its size") from None
    except Exception as exc:  # backends' errors (aiohttp, botocore) share no base
        raise RemoteLogError(url, f"cannot read its size: {first_line(exc)}") from None
    return None if size is None else int(size)


def _copy(filesystem: Any, path: str, copy: Path, url: str, max_bytes: int) -> None:
    """Copy one remote log, refusing it once it passes ``max_bytes``."""
    too_big = f"larger than the {max_bytes} bytes a log behind a URL may have"
    try:
        size = filesystem.size(path)
        if size is not None and size > max_bytes:
            raise RemoteLogError(url, too_big)
        copied = 0
        with (
            filesystem.open(path, "rb", **_streamed(filesystem)) as source,
            copy.open("wb") as target,
        ):
            while block := source.read(_BLOCK):
                copied += len(block)
                if copied > max_bytes:  # a size the listing got wrong
                    raise RemoteLogError(url, too_big)
                target.write(block)
    except FileNotFoundError as exc:
        raise _not_found(url, exc, "cannot copy") from None
    except RemoteLogError:
        raise
    except Exception as exc:  # backends' errors (aiohttp, botocore) share no base
        raise RemoteLogError(url, f"cannot copy: {first_line(exc)}") from None


def _streamed(filesystem: Any) -> dict[str, Any]:
    """How to open a file of ``filesystem`` to read it once from start to end: over HTTP
    as a stream (``block_size=0``), since a server need not serve byte ranges (Python's
    own ``http.server`` does not), which fsspec's random-access HTTP file asks for."""
    protocols = filesystem.protocol
    protocols = (protocols,) if isinstance(protocols, str) else protocols
    return {"block_size": 0} if {"http", "https"} & set(protocols) else {}


def _not_found(url: str, exc: FileNotFoundError, doing: str) -> RemoteLogError:
    """A log not found, or, where the filesystem says so of a server it cannot reach
    (fsspec's HTTP does), what stopped it."""
    cause = exc.__cause__
    if cause is None or isinstance(cause, FileNotFoundError) or getattr(cause, "status", 0) == 404:
        return RemoteLogError(url, "no such log")
    return RemoteLogError(url, f"{doing}: {first_line(cause)}")
