"""A cache of the logs copied from URLs, on this machine's disk, shared by its processes:
a rerun, an audit or a DTC run again on a cluster's worker does not download its log
again.

An entry is keyed by the object's URL and ETag where the storage gives one, else by its
URL, size and time of last change; an object that says neither is never cached. Each
entry's name holds its size and SHA-256 digest, checked before every use: a damaged
entry is removed and the log downloaded again, never replayed. A link of the key's in
``index`` names its entry: finding it lists no folder, however many logs the cache
holds. Entries are written whole before they get their name and used through hard links
of their own, so one process that removes an entry never pulls it from under another;
two that fetch the same object at once share one download (a lock of that object alone,
in ``fetching``). A copy in use lies in the folder of its process, which the process
makes when it first uses the cache and holds locked (``flock``) while it lives; the copy
is removed when its block ends. A folder whose process is gone (killed while it
downloaded or replayed, or ended) is removed by the next process to use the cache and by
every download, so a partial copy is never replayed.

The cache lives in ``BEATLOG_CACHE_DIR`` (the user's cache folder's ``beatlog/logs``
unless set) and holds ``BEATLOG_CACHE_MAX_BYTES`` bytes at most (:data:`MAX_CACHE_BYTES`
unless set; 0 turns the cache off), the least recently used entries going first.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import itertools
import os
import re
import shutil
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

from beatlog.errors import RemoteLogError

__all__ = [
    "CACHE_DIR_VARIABLE",
    "CACHE_MAX_BYTES_VARIABLE",
    "MAX_CACHE_BYTES",
    "cache_folder",
    "cache_key",
    "cached_copy",
    "holds",
]

MAX_CACHE_BYTES = 4 << 30
"""The most bytes of logs the cache holds, unless ``BEATLOG_CACHE_MAX_BYTES`` says
otherwise: a few hundred of the reference dog's hour-long sessions."""
CACHE_DIR_VARIABLE = "BEATLOG_CACHE_DIR"
"""The environment variable that sets the cache's folder."""
CACHE_MAX_BYTES_VARIABLE = "BEATLOG_CACHE_MAX_BYTES"
"""The environment variable that sets the most bytes the cache holds (0: no cache)."""
_ETAGS = ("ETag", "etag")
_CHANGE_TIMES = ("mtime", "LastModified", "Last-Modified", "last_modified", "updated", "created")
_INDEX = "index"
"""The folder of links, one a key, each naming the key's entry."""
_ENTRY = re.compile(r"^[0-9a-f]{64}\.([0-9]+)\.[0-9a-f]{64}$", re.MULTILINE)
"""An entry's name, ``KEY.SIZE.DIGEST``: its size is read from it."""
_OWNER = "owner"
"""The file in a folder of copies in use that its process holds locked."""
_UNLOCKED_GRACE_S = 60.0
"""How old a folder of copies in use whose lock is missing must be to be removed."""
_owned: dict[Path, _OwnFolder] = {}
"""This process's folder of copies in use, by the cache's ``in-use`` folder."""
_owning = threading.Lock()


def cache_key(url: str, info: Mapping[str, Any]) -> str | None:
    """The key of the object behind ``url`` whose storage describes it by ``info`` (an
    fsspec ``info()``): from its ETag, else from its size and time of last change; None
    where it gives neither, and the object is not cached."""
    etag = next((info[name] for name in _ETAGS if info.get(name)), None)
    if etag is not None:
        parts = [url, "etag", str(etag)]
    else:
        changed = next((info[name] for name in _CHANGE_TIMES if info.get(name)), None)
        if changed is None or info.get("size") is None:
            return None
        parts = [url, "size-time", str(info["size"]), str(changed)]
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()


def cache_folder() -> Path:
    """The cache's folder: ``BEATLOG_CACHE_DIR``, or the user's cache folder's
    ``beatlog/logs``."""
    given = os.environ.get(CACHE_DIR_VARIABLE, "").strip()
    if given:
        return Path(given).expanduser()
    import platformdirs  # noqa: PLC0415 - with fsspec, in the fleet extra

    return Path(platformdirs.user_cache_dir("beatlog"), "logs")


def holds(url: str, info: Mapping[str, Any]) -> bool:
    """Whether the cache has an entry for the object behind ``url`` that ``info``
    describes, unchecked: a cheap look before fetching it ahead (its use checks it)."""
    key = cache_key(url, info)
    if key is None or _max_bytes(url) == 0:
        return False
    entry = _entry(cache_folder() / "entries", key)
    return entry is not None and entry.exists()


@contextlib.contextmanager
def cached_copy(
    url: str, info: Mapping[str, Any], name: str, fetch: Callable[[Path], None]
) -> Iterator[Path]:
    """A copy of the log behind ``url`` named ``name``, on this machine until the block
    ends: the cache's where it holds a sound one for the object ``info`` describes, else
    one that ``fetch`` writes to the path it is given (then kept in the cache). Raises
    what ``fetch`` raises, and :class:`RemoteLogError` for a bad cache bound."""
    bound = _max_bytes(url)
    key = cache_key(url, info)
    if bound == 0 or key is None:
        with tempfile.TemporaryDirectory(prefix="beatlog-remote-") as folder:
            fetch(Path(folder, name))
            yield Path(folder, name)
        return
    root = cache_folder()
    entries = root / "entries"
    with _own_folder(root / "in-use").copy(name) as copy:
        if not _used(entries, key, copy):
            _remove_abandoned(root / "in-use")
            entries.mkdir(exist_ok=True)
            with _fetching(root / "fetching", key):
                if not _used(entries, key, copy):  # another process's fetch came first
                    fetch(copy)
                    _keep(entries, key, copy, bound)
        yield copy


@contextlib.contextmanager
def _fetching(folder: Path, key: str) -> Iterator[None]:
    """Hold the lock of fetching the object of ``key`` until the block ends: a process
    that fetches an object another one is fetching waits for that copy."""
    folder.mkdir(exist_ok=True)
    lock = folder / key
    held = os.open(lock, os.O_WRONLY | os.O_CREAT, 0o600)
    try:
        fcntl.flock(held, fcntl.LOCK_EX)
        yield
    finally:
        lock.unlink(missing_ok=True)  # a rare race left: two fetches, no harm
        os.close(held)


class _OwnFolder:
    """This process's folder in a cache's ``in-use``, locked by it while it lives, made
    once the folders of processes gone are removed. A copy lies in a numbered folder of
    its own there, named as the log is; a numbered folder holds one copy at a time and
    is used again once that copy is removed."""

    # Made once a process, not once a copy: a folder made, locked and removed for each
    # copy cost a cache hit of a 3-s rover log (8.6 KiB) 1.0-1.3 ms of CPU and 3.7-4.0 ms
    # of wall time, against 0.26-0.28 ms and 0.3-0.5 ms so (1,000 hits in one process,
    # each a cached_copy of its own URL under one ETag; 2 shared cores); run_spec of such
    # a DTC went from 5.3-6.3 to 3.7-4.1 ms of CPU and from 9-10 to 4 ms of wall time.

    def __init__(self, in_use: Path) -> None:
        in_use.mkdir(parents=True, exist_ok=True)
        _remove_abandoned(in_use)
        self.pid = os.getpid()
        self.folder = Path(tempfile.mkdtemp(dir=in_use))
        unnamed = self.folder / f".{_OWNER}"
        self.owner = os.open(unnamed, os.O_WRONLY | os.O_CREAT, 0o600)  # while it lives
        fcntl.flock(self.owner, fcntl.LOCK_EX)
        unnamed.rename(self.folder / _OWNER)  # locked from the moment it has its name
        self._free: list[Path] = []
        self._made = itertools.count()
        self._lock = threading.Lock()

    @contextlib.contextmanager
    def copy(self, name: str) -> Iterator[Path]:
        """The path of a copy named ``name``, removed when the block ends."""
        with self._lock:
            place = self._free.pop() if self._free else None
        if place is None:
            place = self.folder / str(next(self._made))
            place.mkdir()
        try:
            yield place / name
        finally:
            (place / name).unlink(missing_ok=True)
            with self._lock:
                self._free.append(place)


def _own_folder(in_use: Path) -> _OwnFolder:
    """This process's folder in ``in_use``: made on its first use, by a forked child
    for itself, and again where it was removed (the cache cleared)."""
    with _owning:
        held = _owned.get(in_use)
        if held is not None and held.pid == os.getpid():
            if held.folder.is_dir():
                return held
            os.close(held.owner)
        _owned[in_use] = _OwnFolder(in_use)
        return _owned[in_use]


def _remove_abandoned(in_use: Path) -> None:
    """Remove the folders of copies in use whose process is gone (killed while it
    downloaded or replayed): their lock is free."""
    for folder in in_use.iterdir():
        with contextlib.suppress(FileNotFoundError, NotADirectoryError):  # removed meanwhile
            if _abandoned(folder):
                shutil.rmtree(folder, ignore_errors=True)


def _abandoned(folder: Path) -> bool:
    """Whether no process holds ``folder``, a folder of copies in use (raises
    :class:`FileNotFoundError` where it is gone)."""
    try:
        owner = os.open(folder / _OWNER, os.O_RDONLY)
    except FileNotFoundError:
        return time.time() - folder.stat().st_mtime > _UNLOCKED_GRACE_S
    try:
        fcntl.flock(owner, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    finally:
        os.close(owner)  # lets go of the lock, if taken
    return True


def _entry(entries: Path, key: str) -> Path | None:
    """The entry of ``key`` in ``entries`` as its link in the index names it (None
    where it has none): found without listing the entries, however many there are."""
    try:
        return entries / os.readlink(entries.parent / _INDEX / key)
    except OSError:  # no link: never kept, or removed
        return None


def _used(entries: Path, key: str, copy: Path) -> bool:
    """Whether a sound entry of ``key`` is now at ``copy``; a damaged one is removed."""
    entry = _entry(entries, key)
    if entry is None:
        return False
    _, size, digest = entry.name.split(".", 2)
    with contextlib.suppress(FileNotFoundError):  # another process removed it
        _link(entry, copy)
        if copy.stat().st_size == int(size) and _digest(copy) == digest:
            os.utime(entry)  # recently used: the last to go
            return True
        entry.unlink(missing_ok=True)
    copy.unlink(missing_ok=True)
    return False


def _keep(entries: Path, key: str, copy: Path, bound: int) -> None:
    """Add ``copy`` to the cache under ``key``, then remove the least recently used
    entries past ``bound`` bytes; a copy larger than the bound is not kept."""
    size = copy.stat().st_size
    if size > bound:
        return
    name = f"{key}.{size}.{_digest(copy)}"
    with contextlib.suppress(FileExistsError):  # another process kept the same copy
        _link(copy, entries / name)
    index = entries.parent / _INDEX
    index.mkdir(exist_ok=True)
    link = index / f".{key}.{os.getpid()}.{threading.get_ident()}"
    link.unlink(missing_ok=True)
    os.symlink(name, link)
    link.replace(index / key)  # whole, or not at all
    names = os.listdir(entries)
    total = sum(map(int, _ENTRY.findall("\n".join(names))))
    if total <= bound:  # the sizes are in the names: nothing read but the folder
        return
    kept = []
    for name in names:
        with contextlib.suppress(FileNotFoundError):
            status = (entries / name).stat()
            kept.append((status.st_mtime, status.st_size, entries / name))
    for _, size, entry in sorted(kept):
        if total <= bound:
            break
        entry.unlink(missing_ok=True)
        (entries.parent / _INDEX / entry.name.partition(".")[0]).unlink(missing_ok=True)
        total -= size


def _link(source: Path, target: Path) -> None:
    """``target`` as a hard link to ``source``, or, on a filesystem without links, a
    copy written whole before it gets its name (:class:`FileExistsError` if it exists)."""
    try:
        os.link(source, target)
    except (FileExistsError, FileNotFoundError):
        raise
    except OSError:
        partial = target.with_name(f".{target.name}.{os.getpid()}")
        shutil.copyfile(source, partial)
        if target.exists():
            partial.unlink()
            raise FileExistsError(target) from None
        partial.replace(target)


def _digest(path: Path) -> str:
    """The SHA-256 digest of a file, in hex."""
    with path.open("rb") as file:
        return hashlib.file_digest(file, "sha256").hexdigest()


def _max_bytes(url: str) -> int:
    """The most bytes the cache holds; a :class:`RemoteLogError` where
    ``BEATLOG_CACHE_MAX_BYTES`` holds no whole number from 0."""
    text = os.environ.get(CACHE_MAX_BYTES_VARIABLE, "").strip()
    if not text:
        return MAX_CACHE_BYTES
    if not text.isdigit():
        raise RemoteLogError(url, f"{CACHE_MAX_BYTES_VARIABLE}={text}: not a number of bytes")
    return int(text)
