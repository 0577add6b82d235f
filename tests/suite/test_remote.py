"""Logs behind URLs: copied whole, within bounds of size, waiting and rate, by the
process that reads them and removed after; never a partial copy; sized without being
read; every problem one line naming the URL."""

from __future__ import annotations

import io
import re
import sys
import tempfile
import tomllib
from collections.abc import Iterator
from pathlib import Path

import fsspec
import pytest
from packaging.requirements import Requirement

from beatlog.errors import RemoteLogError
from beatlog.suite.remote import (
    MAX_BYTES_VARIABLE,
    TIMEOUT_VARIABLE,
    Listed,
    fetch_ahead,
    fetched_log,
    is_url,
    log_size,
    url_name,
    wait_for,
)
from tests.commands import plain
from tests.served import LogServer

UNFRAMED = (
    "the server sent neither its length nor a chunked body: "
    "a download cut off could not be told from the whole log"
)


class Terminal(io.StringIO):
    """A stderr that says it is a terminal."""

    def isatty(self) -> bool:
        return True


@pytest.fixture
def memory(tmp_path: Path) -> Iterator[str]:
    """A small file in fsspec's in-memory filesystem, under a folder of this test's own."""
    filesystem = fsspec.filesystem("memory")
    folder = f"/{tmp_path.name}"
    filesystem.pipe(f"{folder}/walk.beatlog", b"x" * 1000)
    yield f"memory://{folder}/walk.beatlog"
    filesystem.rm(folder, recursive=True)


@pytest.mark.parametrize(
    ("text", "url"),
    [
        ("s3://bucket/a.beatlog", True),
        ("https://host/a.beatlog", True),
        ("file:///tmp/a.beatlog", True),
        ("logs/a.beatlog", False),
        ("/abs/a.beatlog", False),
        ("c:/logs/a.beatlog", False),
    ],
)
def test_a_url_has_a_scheme_and_two_slashes(text: str, url: bool) -> None:
    assert is_url(text) is url


def test_a_url_is_named_after_the_file_at_the_end_of_its_path() -> None:
    assert url_name("https://host/suite/walk.beatlog?x=1") == "walk.beatlog"


@pytest.mark.parametrize(
    ("url", "name"),
    [
        (
            "http://host/with%20space%20%26%20odd%23name%2520.beatlog",
            "with space & odd#name%20.beatlog",
        ),
        ("https://host/dock%2Fyard.beatlog", "dock%2Fyard.beatlog"),  # no folder in a name
        ("s3://bucket/with%20space.beatlog", "with%20space.beatlog"),  # a key's % is a %
    ],
)
def test_an_http_url_names_its_file_as_the_server_does(url: str, name: str) -> None:
    assert url_name(url) == name


def test_a_fetched_log_is_a_copy_removed_when_the_block_ends(served: LogServer) -> None:
    with fetched_log(f"{served.url}/dock.beatlog") as copy:
        assert copy.name == "dock.beatlog"
        assert copy.read_bytes() == (served.folder / "dock.beatlog").read_bytes()

    assert not copy.exists()
    assert served.downloads("dock.beatlog") == 1


def test_a_log_is_copied_from_a_server_that_serves_no_byte_ranges(served: LogServer) -> None:
    big = served.folder / "big.beatlog"
    big.write_bytes(bytes(range(256)) * 40_000)  # 10 MB, past fsspec's HTTP block size

    with fetched_log(f"{served.url}/big.beatlog") as copy:
        assert copy.read_bytes() == big.read_bytes()

    assert served.downloads("big.beatlog") == 1


@pytest.fixture
def temporary(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The folder temporary copies go to in this test."""
    folder = tmp_path / "temporary"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


def test_a_log_larger_than_the_bound_is_refused(
    memory: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(MAX_BYTES_VARIABLE, "100")
    with pytest.raises(RemoteLogError) as raised, fetched_log(memory):
        pass

    assert str(raised.value) == (
        f"{memory}: larger than the 100 bytes a log behind a URL may have (BEATLOG_URL_MAX_BYTES)"
    )


def test_an_endless_log_is_refused_at_the_bound_the_environment_sets(
    served: LogServer, temporary: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(MAX_BYTES_VARIABLE, "1000000")
    url = f"{served.url}/endless/dock.beatlog"

    with pytest.raises(RemoteLogError) as raised, fetched_log(url):
        pass

    assert str(raised.value) == (
        f"{url}: larger than the 1000000 bytes a log behind a URL may have (BEATLOG_URL_MAX_BYTES)"
    )
    assert list(temporary.iterdir()) == []


@pytest.mark.parametrize("way", ["cut-length", "cut-chunked"])
def test_a_download_cut_off_where_the_server_said_its_end_is_an_error(
    served: LogServer, temporary: Path, way: str
) -> None:
    url = f"{served.url}/{way}/dock.beatlog"

    with pytest.raises(RemoteLogError) as raised, fetched_log(url):
        pass

    assert str(raised.value).startswith(f"{url}: cannot copy: Response payload is not completed")
    assert "\n" not in str(raised.value)
    assert list(temporary.iterdir()) == []


def test_a_download_shorter_than_the_size_listed_is_an_error(served: LogServer) -> None:
    url = f"{served.url}/cut-listed/dock.beatlog"
    size = (served.folder / "dock.beatlog").stat().st_size

    with pytest.raises(RemoteLogError) as raised, fetched_log(url):
        pass

    assert str(raised.value) == (
        f"{url}: download cut off or changed: {size // 2} of its {size} bytes"
    )


@pytest.mark.parametrize("way", ["cut-close", "close"])
def test_a_body_that_ends_where_the_connection_does_is_refused(served: LogServer, way: str) -> None:
    url = f"{served.url}/{way}/dock.beatlog"

    with pytest.raises(RemoteLogError) as raised, fetched_log(url):
        pass

    assert str(raised.value) == f"{url}: {UNFRAMED}"


def test_a_chunked_body_is_copied_whole(served: LogServer) -> None:
    with fetched_log(f"{served.url}/chunked/dock.beatlog") as copy:
        assert copy.read_bytes() == (served.folder / "dock.beatlog").read_bytes()


@pytest.mark.parametrize(
    ("variable", "value", "problem"),
    [
        (TIMEOUT_VARIABLE, "soon", "BEATLOG_URL_TIMEOUT=soon: not a number of seconds above 0"),
        (TIMEOUT_VARIABLE, "0", "BEATLOG_URL_TIMEOUT=0: not a number of seconds above 0"),
        (TIMEOUT_VARIABLE, "nan", "BEATLOG_URL_TIMEOUT=nan: not a number of seconds above 0"),
        (MAX_BYTES_VARIABLE, "1e9", "BEATLOG_URL_MAX_BYTES=1e9: not a number of bytes above 0"),
        (MAX_BYTES_VARIABLE, "-1", "BEATLOG_URL_MAX_BYTES=-1: not a number of bytes above 0"),
    ],
)
def test_a_bound_the_environment_gets_wrong_is_named(
    served: LogServer,
    monkeypatch: pytest.MonkeyPatch,
    variable: str,
    value: str,
    problem: str,
) -> None:
    monkeypatch.setenv(variable, value)
    url = f"{served.url}/dock.beatlog"

    with pytest.raises(RemoteLogError) as raised, fetched_log(url):
        pass

    assert str(raised.value) == f"{url}: {problem}"


def test_a_big_download_shows_its_progress_on_a_terminal(
    served: LogServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    (served.folder / "big.beatlog").write_bytes(b"x" * 100_000)
    monkeypatch.setattr("beatlog.suite.remote.PROGRESS_BYTES", 50_000)
    monkeypatch.setattr(sys, "stderr", stderr := Terminal())

    with fetched_log(f"{served.url}/big.beatlog", progress=True):
        pass

    last = plain(stderr.getvalue()).split("\r")[-2].rstrip("\n")
    assert re.fullmatch(r"big\.beatlog ━+ 100\.0/100\.0 kB .+", last), last


@pytest.mark.parametrize(("progress", "terminal"), [(True, False), (False, True)])
def test_a_download_shows_no_progress_off_a_terminal_or_unasked(
    served: LogServer, monkeypatch: pytest.MonkeyPatch, progress: bool, terminal: bool
) -> None:
    monkeypatch.setattr("beatlog.suite.remote.PROGRESS_BYTES", 0)
    monkeypatch.setattr(sys, "stderr", stderr := Terminal() if terminal else io.StringIO())

    with fetched_log(f"{served.url}/dock.beatlog", progress=progress):
        pass

    assert stderr.getvalue() == ""


def test_a_log_not_found_is_named(served: LogServer) -> None:
    url = f"{served.url}/lost.beatlog"

    with pytest.raises(RemoteLogError) as raised, fetched_log(url):
        pass

    assert str(raised.value) == f"{url}: no such log"


def test_a_server_that_cannot_be_reached_is_one_line() -> None:
    url = "http://127.0.0.1:9/dock.beatlog"  # the discard port: nothing listens there

    with pytest.raises(RemoteLogError) as raised, fetched_log(url):
        pass

    assert str(raised.value).startswith(f"{url}: cannot copy: ")
    assert "\n" not in str(raised.value)


def test_a_log_is_sized_without_being_read(served: LogServer) -> None:
    size = log_size(f"{served.url}/dock.beatlog")

    assert size == (served.folder / "dock.beatlog").stat().st_size
    assert served.downloads("dock.beatlog") == 0


def test_the_size_of_a_missing_log_is_an_error(memory: str) -> None:
    with pytest.raises(RemoteLogError, match=r": no such log$"):
        log_size(memory.replace("walk", "lost"))


def test_a_url_without_fsspec_says_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in [name for name in sys.modules if name.startswith("fsspec")]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, "fsspec", None)

    with pytest.raises(RemoteLogError) as raised, fetched_log("s3://bucket/a.beatlog"):
        pass

    assert str(raised.value) == (
        's3://bucket/a.beatlog: a URL needs fsspec (pip install "beatlog[fleet]")'
    )


def test_the_fleet_extra_brings_what_http_urls_and_the_cache_need() -> None:
    pyproject = Path(__file__).parents[2] / "pyproject.toml"
    extras = tomllib.loads(pyproject.read_text(encoding="utf-8"))["project"]
    fleet = [Requirement(line) for line in extras["optional-dependencies"]["fleet"]]

    assert [(req.name, req.extras) for req in fleet] == [
        ("fsspec", {"http"}),
        ("platformdirs", set()),
    ]


def test_an_http_url_without_aiohttp_is_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "aiohttp", None)
    url = "http://127.0.0.1:9/dock.beatlog"

    with pytest.raises(RemoteLogError) as raised, fetched_log(url):
        pass

    assert str(raised.value) == f"{url}: cannot open: import of aiohttp halted; None in sys.modules"


# a log a listing found: its size and ETag already said


def listed(served: LogServer, name: str, etag: str) -> Listed:
    return Listed((served.folder / name).stat().st_size, etag)


def test_a_listed_log_is_one_request_and_none_once_in_the_cache(served: LogServer) -> None:
    url = f"{served.url}/dock.beatlog"
    for _ in range(2):
        with fetched_log(url, listed=listed(served, "dock.beatlog", '"v1"')) as copy:
            assert copy.read_bytes() == (served.folder / "dock.beatlog").read_bytes()

    assert served.requests == {"GET /dock.beatlog": 1}


def test_a_listed_log_in_the_cache_needs_no_package_of_its_storage(
    served: LogServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    url, whole = f"{served.url}/dock.beatlog", (served.folder / "dock.beatlog").read_bytes()
    with fetched_log(url, listed=listed(served, "dock.beatlog", '"v1"')):
        pass
    monkeypatch.setitem(sys.modules, "aiohttp", None)  # what fsspec's HTTP needs

    with fetched_log(url, listed=listed(served, "dock.beatlog", '"v1"')) as copy:
        assert copy.read_bytes() == whole


def test_a_log_listed_with_another_etag_is_fetched_again(served: LogServer) -> None:
    url = f"{served.url}/dock.beatlog"
    with fetched_log(url, listed=listed(served, "dock.beatlog", '"v1"')):
        pass

    with fetched_log(url, listed=listed(served, "dock.beatlog", '"v2"')):
        pass

    assert served.requests == {"GET /dock.beatlog": 2}


def test_a_log_no_listing_found_is_asked_its_size_once_before_its_download(
    served: LogServer,
) -> None:
    with fetched_log(f"{served.url}/dock.beatlog"):
        pass

    assert served.requests == {"HEAD /dock.beatlog": 1, "GET /dock.beatlog": 1}


# fetching logs ahead


def test_a_log_fetched_ahead_is_replayed_from_the_cache(served: LogServer) -> None:
    url = f"{served.url}/dock.beatlog"
    fetch_ahead(url)
    fetch_ahead(url)  # already at it: not twice
    wait_for(url)

    with fetched_log(url) as copy:
        assert copy.read_bytes() == (served.folder / "dock.beatlog").read_bytes()
    assert served.downloads("dock.beatlog") == 1


def test_a_log_that_cannot_be_fetched_ahead_is_left_to_its_dtc(served: LogServer) -> None:
    url = f"{served.url}/lost.beatlog"
    fetch_ahead(url)
    wait_for(url)

    wait_for(f"{served.url}/never-asked.beatlog")


def test_a_listed_log_fetched_ahead_is_one_request(served: LogServer) -> None:
    url = f"{served.url}/dock.beatlog"
    listed = Listed((served.folder / "dock.beatlog").stat().st_size, '"v1"')
    fetch_ahead(url, listed)
    wait_for(url)

    with fetched_log(url, listed=listed):
        pass

    assert served.requests == {"GET /dock.beatlog": 1}
