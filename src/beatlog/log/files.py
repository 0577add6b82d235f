"""The files users name, handled safely: read only when regular (nothing read can block),
written whole or not at all (readers, and a Ctrl-C, never see half of one); and the
project they belong to."""

from __future__ import annotations

import contextlib
import json
import os
import stat
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Self

__all__ = [
    "ZSTD_MAGIC",
    "Closing",
    "irregular_file_problem",
    "project_root",
    "read_small_text",
    "read_text_blocks",
    "replacing",
    "write_json",
]

ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"
"""How a zstd frame starts: a file that does is read as the text it holds compressed."""


def irregular_file_problem(path: Path) -> str | None:
    """Why ``path`` cannot be read as a file, or None when it is a regular file: a FIFO,
    socket or device could block a reader or never end, so it is refused unopened."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return "no such file"
    except OSError as exc:
        return f"cannot open: {exc.strerror}"
    if stat.S_ISDIR(mode):
        return "is a directory"
    if not stat.S_ISREG(mode):
        return "is not a regular file (a FIFO, socket or device)"
    return None


def read_small_text(
    path: Path, *, limit: int, kind: str, error: Callable[[Path, str], Exception]
) -> str:
    """The UTF-8 text of a small file of ``kind`` (a spec, a baseline); a file that is
    not a regular one, is larger than ``limit`` bytes or cannot be read as UTF-8 raises
    ``error(path, problem)``."""
    _check_size(path, limit=limit, kind=kind, error=error)
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise error(path, f"cannot read: {exc}") from None


def read_text_blocks(
    path: Path,
    *,
    limit: int,
    kind: str,
    error: Callable[[Path, str], Exception],
    block_bytes: int,
) -> Iterator[str]:
    """The UTF-8 text of a file of ``kind`` (a baseline) in blocks of whole lines, each
    of about ``block_bytes`` and ended by a line feed (the last perhaps not), so that a
    large file is read in bounded memory; refused as :func:`read_small_text` refuses
    one, a block that cannot be read as UTF-8 raising ``error`` too. A file of zstd
    frames (:data:`ZSTD_MAGIC`) is read as the text they hold, which may not be longer
    than ``limit`` bytes either: it is refused as soon as it is."""
    _check_size(path, limit=limit, kind=kind, error=error)
    read = 0
    damaged: tuple[type[Exception], ...] = ()
    try:
        with path.open("rb") as raw:
            file: IO[bytes] = raw
            if raw.read(len(ZSTD_MAGIC)) == ZSTD_MAGIC:
                import zstandard  # noqa: PLC0415 - only a compressed file needs it

                damaged = (zstandard.ZstdError,)
                file = zstandard.ZstdDecompressor().stream_reader(raw, read_across_frames=True)
            raw.seek(0)
            rest = b""
            while block := file.read(block_bytes):
                if read + len(rest) + len(block) > limit:
                    raise error(path, f"holds more than {limit} bytes of text; not a {kind}")
                end = block.rfind(b"\n") + 1
                if not end:  # a line longer than a block: read on to its end
                    rest += block
                    continue
                text, rest = rest + block[:end], block[end:]
                yield text.decode("utf-8")
                read += len(text)
            if rest:
                yield rest.decode("utf-8")
    except OSError as exc:
        raise error(path, f"cannot read: {exc}") from None
    except UnicodeDecodeError as exc:
        raise error(
            path, f"cannot read: {exc.reason} at byte {read + exc.start} (not UTF-8 text)"
        ) from None
    except damaged as exc:
        raise error(path, f"cannot read: damaged zstd data ({exc})") from None


def _check_size(
    path: Path, *, limit: int, kind: str, error: Callable[[Path, str], Exception]
) -> None:
    """Refuse a file that is not a regular one, or is larger than ``limit`` bytes."""
    problem = irregular_file_problem(path)
    if problem is not None:
        raise error(path, problem)
    if path.stat().st_size > limit:
        raise error(path, f"is larger than {limit} bytes; not a {kind}")


def project_root(start: Path) -> Path | None:
    """The nearest folder at or above ``start`` holding a ``pyproject.toml``, as pytest
    finds its rootdir; None when there is none."""
    start = start.resolve()
    return next(
        (folder for folder in (start, *start.parents) if (folder / "pyproject.toml").is_file()),
        None,
    )


@contextlib.contextmanager
def replacing(path: Path) -> Iterator[IO[bytes]]:
    """A new file beside ``path`` that replaces it when the block ends, and is removed
    if the block raises (Ctrl-C included)."""
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with temporary.open("wb") as file:
            yield file
        temporary.replace(path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def write_json(path: Path, document: object) -> None:
    """Write a JSON document for tools, whole or not at all.

    :raises OSError: the path cannot be written.
    """
    with replacing(path) as file:
        file.write(json.dumps(document, indent=2).encode() + b"\n")


class Closing:
    """A context manager for an object with :meth:`close`: the ``with`` block ends by
    closing it, whether the block raised or not. One shape for everything beatlog opens
    and must close."""

    def close(self) -> None:
        """Release what the object holds (a file, a thread, a process)."""
        raise NotImplementedError

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
