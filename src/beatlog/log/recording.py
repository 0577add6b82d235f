"""A session log read once: its SHA-256 taken as its bytes stream past, and the bytes
kept in memory (up to a bound) for whatever looks at it again.

The verdict's read of a :class:`Recording` hashes every byte for the digest that binds
a baseline to its recording, and keeps them, so that the details of a failure and the
weighing of a pending baseline replay the same bytes: the file is opened once.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["KEPT_BYTES", "LogSource", "Recording"]

KEPT_BYTES = 64 << 20
"""The most bytes of a log a :class:`Recording` keeps in memory: a larger log is
hashed as it streams, but looked at again from its file."""


@dataclass(eq=False)
class Recording(os.PathLike[str]):
    """A log at ``path``, read once: whatever reads it first hashes its bytes and keeps
    up to ``keep`` of them for the readers after it. It stands for its path wherever one
    is wanted (``os.fspath``, ``Path(recording)``)."""

    path: Path
    keep: int = KEPT_BYTES
    digest: str | None = None
    """The SHA-256 of the whole file, once a read has reached its end (hex)."""
    data: bytes | None = None
    """The whole file, once a read has reached its end and it holds at most ``keep`` bytes."""
    _hash: hashlib._Hash | None = field(default=None, repr=False)
    _pieces: list[bytes] | None = field(default=None, repr=False)
    _read: int = field(default=0, repr=False)

    def __fspath__(self) -> str:
        return os.fspath(self.path)

    def __str__(self) -> str:
        return str(self.path)

    def __getstate__(self) -> dict[str, object]:
        """What a copy in another process holds: no read under way."""
        return {**self.__dict__, "_hash": None, "_pieces": None, "_read": 0}

    def start(self) -> None:
        """A read of the file from its first byte begins: hashing and keeping start over."""
        self._hash = hashlib.sha256()
        self._pieces = []
        self._read = 0

    def take(self, piece: bytes) -> None:
        """The next bytes of the file, in order."""
        if self._hash is None:
            return
        self._hash.update(piece)
        self._read += len(piece)
        if self._pieces is not None:
            if self._read > self.keep:
                self._pieces = None
            else:
                self._pieces.append(piece)

    def ended(self, size: int) -> None:
        """The read reached the end of the file, ``size`` bytes: the digest is known
        where every byte went through :meth:`take`."""
        if self._hash is None or self._read != size:
            self._hash = self._pieces = None
            return
        self.digest = self._hash.hexdigest()
        self.data = None if self._pieces is None else b"".join(self._pieces)
        self._hash = self._pieces = None


LogSource = str | Path | Recording
"""A log to read: its path, or a :class:`Recording` of it."""
