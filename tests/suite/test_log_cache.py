"""The cache of logs copied from URLs: keyed by what the storage says of the object,
bounded in size with the least recently used entries going first, never replaying a
damaged entry, and a changed object downloaded again."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import fsspec
import pytest

from beatlog.errors import RemoteLogError
from beatlog.suite.log_cache import (
    CACHE_DIR_VARIABLE,
    CACHE_MAX_BYTES_VARIABLE,
    cache_folder,
    cache_key,
    holds,
)
from beatlog.suite.remote import Listed, fetched_log
from tests.conftest import RecordFn
from tests.served import LogServer

URL = "s3://fleet/dock.beatlog"


@pytest.fixture
def memory(tmp_path: Path) -> Iterator[str]:
    """A folder of this test's own in fsspec's in-memory filesystem."""
    filesystem = fsspec.filesystem("memory")
    folder = f"/{tmp_path.name}"
    filesystem.mkdir(folder)
    yield f"memory://{folder}"
    filesystem.rm(folder, recursive=True)


def fetched(url: str, size: int | None = None) -> bytes:
    """The log behind ``url``, as a listing of ``size`` and ETag ``v1`` finds it if given."""
    with fetched_log(url, listed=None if size is None else Listed(size, "v1")) as copy:
        return copy.read_bytes()


def sent(served: LogServer, name: str) -> int:
    with served.lock:
        return served.sent[f"/{name}"]


def test_an_objects_etag_keys_it_whatever_its_time_of_change() -> None:
    tagged = {"size": 10, "ETag": '"abc"', "LastModified": "2026-11-28T10:00:00"}

    assert cache_key(URL, tagged) == cache_key(URL, {**tagged, "LastModified": "later"})
    assert cache_key(URL, tagged) != cache_key(URL, {**tagged, "ETag": '"abd"'})
    assert cache_key(URL, tagged) != cache_key("s3://fleet/yard.beatlog", tagged)


def test_without_an_etag_size_and_time_of_change_key_an_object() -> None:
    dated = {"size": 10, "mtime": 1_700_000_000.0}

    assert cache_key(URL, dated) == cache_key(URL, dict(dated))
    assert cache_key(URL, dated) != cache_key(URL, {**dated, "size": 11})
    assert cache_key(URL, dated) != cache_key(URL, {**dated, "mtime": 1_700_000_001.0})
    assert cache_key(URL, {**dated, "ETag": '"abc"'}) != cache_key(URL, dated)


def test_an_object_that_says_neither_etag_nor_time_of_change_is_not_cached() -> None:
    assert cache_key(URL, {"size": 10}) is None


def test_a_log_fetched_again_comes_from_the_cache(served: LogServer) -> None:
    url = f"{served.url}/dock.beatlog"
    first = fetched(url)

    assert fetched(url) == first == (served.folder / "dock.beatlog").read_bytes()
    assert served.downloads("dock.beatlog") == 1


def test_a_changed_object_is_fetched_again(memory: str) -> None:
    filesystem = fsspec.filesystem("memory")
    url = f"{memory}/dock.beatlog"
    filesystem.pipe(url, b"before")
    assert fetched(url) == b"before"

    filesystem.pipe(url, b"after!")

    assert fetched(url) == b"after!"


def test_a_changed_file_on_a_web_server_is_fetched_again(served: LogServer) -> None:
    url = f"{served.url}/dock.beatlog"
    log = served.folder / "dock.beatlog"
    fetched(url)
    changed = log.read_bytes()[::-1]
    log.write_bytes(changed)
    os.utime(log, (log.stat().st_atime, log.stat().st_mtime + 10))

    assert fetched(url) == changed
    assert sent(served, "dock.beatlog") == 2 * len(changed)


def test_a_damaged_cache_entry_is_fetched_again_never_replayed(
    served: LogServer, log_cache: Path
) -> None:
    url = f"{served.url}/dock.beatlog"
    whole = fetched(url)
    [entry] = (log_cache / "entries").iterdir()
    damaged = bytearray(entry.read_bytes())
    damaged[len(damaged) // 2] ^= 0xFF
    entry.write_bytes(damaged)

    assert fetched(url) == whole
    assert served.downloads("dock.beatlog") == 2
    assert fetched(url) == whole
    assert served.downloads("dock.beatlog") == 2


def test_a_cut_cache_entry_is_fetched_again(served: LogServer, log_cache: Path) -> None:
    url = f"{served.url}/dock.beatlog"
    whole = fetched(url)
    [entry] = (log_cache / "entries").iterdir()
    entry.write_bytes(whole[:100])

    assert fetched(url) == whole
    assert served.downloads("dock.beatlog") == 2


def test_the_cache_keeps_its_bound_the_least_recently_used_going_first(
    served: LogServer, record_probe: RecordFn, monkeypatch: pytest.MonkeyPatch
) -> None:
    record_probe(200, name="served/gate.beatlog")
    sizes = {
        name: (served.folder / name).stat().st_size for name in ("dock.beatlog", "yard.beatlog")
    }
    monkeypatch.setenv(CACHE_MAX_BYTES_VARIABLE, str(sum(sizes.values()) + 100))
    for name in ("dock.beatlog", "yard.beatlog", "dock.beatlog", "gate.beatlog"):
        fetched(f"{served.url}/{name}")

    fetched(f"{served.url}/dock.beatlog")
    fetched(f"{served.url}/yard.beatlog")

    assert served.downloads("dock.beatlog") == 1
    assert served.downloads("yard.beatlog") == 2


def test_a_log_larger_than_the_cache_is_not_kept(
    served: LogServer, monkeypatch: pytest.MonkeyPatch, log_cache: Path
) -> None:
    monkeypatch.setenv(CACHE_MAX_BYTES_VARIABLE, "1000")
    fetched(f"{served.url}/dock.beatlog")
    fetched(f"{served.url}/dock.beatlog")

    assert served.downloads("dock.beatlog") == 2
    assert list((log_cache / "entries").iterdir()) == []


def test_the_cache_holds_a_listed_object_once_fetched_and_not_once_changed(
    served: LogServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    url = f"{served.url}/dock.beatlog"
    size = (served.folder / "dock.beatlog").stat().st_size
    listed = {"size": size, "ETag": "v1"}
    before = holds(url, listed)

    fetched(url, size)

    assert (before, holds(url, listed), holds(url, {**listed, "ETag": "v2"})) == (
        False,
        True,
        False,
    )
    monkeypatch.setenv(CACHE_MAX_BYTES_VARIABLE, "0")
    assert not holds(url, listed)


def test_a_cache_of_0_bytes_is_none(
    served: LogServer, monkeypatch: pytest.MonkeyPatch, log_cache: Path
) -> None:
    monkeypatch.setenv(CACHE_MAX_BYTES_VARIABLE, "0")
    fetched(f"{served.url}/dock.beatlog")
    fetched(f"{served.url}/dock.beatlog")

    assert served.downloads("dock.beatlog") == 2
    assert not log_cache.joinpath("entries").exists()


def test_a_cache_bound_that_is_no_number_is_one_line(
    served: LogServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(CACHE_MAX_BYTES_VARIABLE, "lots")
    url = f"{served.url}/dock.beatlog"

    with pytest.raises(RemoteLogError) as raised, fetched_log(url):
        pass

    assert str(raised.value) == f"{url}: {CACHE_MAX_BYTES_VARIABLE}=lots: not a number of bytes"


def test_the_copy_in_use_is_gone_after_the_block_and_the_entry_stays(
    served: LogServer, log_cache: Path
) -> None:
    with fetched_log(f"{served.url}/dock.beatlog") as copy:
        assert copy.name == "dock.beatlog"

    assert not copy.exists()
    [folder] = in_use(log_cache)  # this process's, which it holds while it lives
    assert list(folder.glob("*/*")) == []
    assert len(list((log_cache / "entries").iterdir())) == 1


def test_copies_of_one_log_at_once_in_one_process_are_its_own_each(
    served: LogServer, log_cache: Path
) -> None:
    url = f"{served.url}/dock.beatlog"
    with fetched_log(url) as first, fetched_log(url) as second:
        assert first != second
        assert first.name == second.name == "dock.beatlog"
        first.unlink()
        assert second.read_bytes() == (served.folder / "dock.beatlog").read_bytes()
    with fetched_log(url) as again:
        assert again.parent == first.parent  # a folder of its process's, used again
    assert len(in_use(log_cache)) == 1


def test_the_cache_is_in_the_users_cache_folder_unless_set(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv(CACHE_DIR_VARIABLE)

    assert cache_folder().parts[-2:] == ("beatlog", "logs")


# copies in use: a process killed while it fetched or replayed leaves its folder


HOLD = """
import sys, threading
from beatlog.suite import remote
listed = remote.Listed(int(sys.argv[2]), "v1") if len(sys.argv) > 2 else None
with remote.fetched_log(sys.argv[1], **({} if listed is None else {"listed": listed})) as copy:
    print(copy.parent.parent, flush=True)
    threading.Event().wait()
"""


@contextlib.contextmanager
def holding(url: str) -> Iterator[tuple[subprocess.Popen[str], Path]]:
    """Another process that holds a copy of the log behind ``url`` until killed, and its
    folder of copies in use."""
    with subprocess.Popen(
        [sys.executable, "-c", HOLD, url], stdout=subprocess.PIPE, text=True
    ) as process:
        try:
            assert process.stdout is not None
            yield process, Path(process.stdout.readline().strip())
        finally:
            process.kill()


def in_use(log_cache: Path) -> list[Path]:
    return sorted((log_cache / "in-use").iterdir())


def test_the_folder_of_a_process_killed_while_fetching_is_removed_never_replayed(
    served: LogServer, log_cache: Path
) -> None:
    stalled = f"{served.url}/stall/dock.beatlog"  # promises the log, never sends it
    size = str((served.folder / "dock.beatlog").stat().st_size)
    with subprocess.Popen([sys.executable, "-c", HOLD, stalled, size]) as process:
        while not list((log_cache / "in-use").glob("*/*/dock.beatlog")):
            assert process.poll() is None
            time.sleep(0.05)
        process.kill()
    [left] = in_use(log_cache)

    whole = fetched(f"{served.url}/dock.beatlog")

    assert whole == (served.folder / "dock.beatlog").read_bytes()
    assert left not in in_use(log_cache)
    assert not left.exists()


def test_the_folder_of_a_process_killed_while_replaying_is_removed(
    served: LogServer, log_cache: Path
) -> None:
    url = f"{served.url}/dock.beatlog"
    with holding(url) as (process, folder):
        assert in_use(log_cache) == [folder]
        process.kill()
        process.wait()

    fetched(url)

    assert folder not in in_use(log_cache)
    assert not folder.exists()
    assert served.downloads("dock.beatlog") == 1


def test_the_folder_of_a_live_process_is_kept(served: LogServer, log_cache: Path) -> None:
    url = f"{served.url}/dock.beatlog"
    with holding(url) as (_, folder):
        fetched(url)

        assert folder in in_use(log_cache)
        [copy] = folder.glob("*/dock.beatlog")
        assert copy.read_bytes() == fetched(url)


def test_a_folder_in_use_without_its_lock_is_removed_once_a_minute_old(
    served: LogServer, log_cache: Path
) -> None:
    fetched(f"{served.url}/dock.beatlog")  # makes the cache's folders and this process's
    [mine] = in_use(log_cache)
    old, new = log_cache / "in-use" / "old", log_cache / "in-use" / "new"
    for folder in (old, new):
        folder.mkdir()
        (folder / "dock.beatlog").write_bytes(b"partial")
    os.utime(old, (old.stat().st_atime, old.stat().st_mtime - 61))

    fetched(f"{served.url}/yard.beatlog")  # a download

    assert in_use(log_cache) == sorted([mine, new])


def test_a_log_another_process_is_fetching_is_waited_for_not_fetched_again(
    served: LogServer, log_cache: Path
) -> None:
    url = f"{served.url}/gated/dock.beatlog"  # sent once the gate opens
    size = (served.folder / "dock.beatlog").stat().st_size
    copies: list[bytes] = []
    with subprocess.Popen([sys.executable, "-c", HOLD, url, str(size)]) as process:
        try:
            while not list((log_cache / "in-use").glob("*/*/dock.beatlog")):
                assert process.poll() is None
                time.sleep(0.05)
            here = threading.Thread(target=lambda: copies.append(fetched(url, size)))
            here.start()
            while len(in_use(log_cache)) < 2:  # this process's copy is under way
                assert here.is_alive()
                time.sleep(0.05)
            time.sleep(0.2)  # time to ask for it too, were it not waiting
            served.gate.set()
            here.join()
        finally:
            process.kill()

    assert copies == [(served.folder / "dock.beatlog").read_bytes()]
    assert served.requests["GET /gated/dock.beatlog"] == 1
