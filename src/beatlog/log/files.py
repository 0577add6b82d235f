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
    "Closing",
    "check_size",
    "irregular_file_problem",
    "project_root",
    "read_small_text",
    "replacing",
    "write_json",
]


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
    """The UTF-8 text of a small file of ``kind`` (a spec); a file that is
    not a regular one, is larger than ``limit`` bytes or cannot be read as UTF-8 raises
    ``error(path, problem)``."""
    check_size(path, limit=limit, kind=kind, error=error)
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise error(path, f"cannot read: {exc}") from None


def check_size(
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
