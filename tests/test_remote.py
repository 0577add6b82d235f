"""Logs behind URLs: copied whole, within a bound, by the process that reads them and
removed after; sized without being read; every problem one line naming the URL."""

from __future__ import annotations

import sys
import tomllib
from collections.abc import Iterator
from pathlib import Path

import fsspec
import pytest
from packaging.requirements import Requirement

from beatlog.errors import RemoteLogError
from beatlog.remote import fetched_log, is_url, log_size, url_name
from tests.served import LogServer


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


def test_a_log_larger_than_the_bound_is_refused(memory: str) -> None:
    with pytest.raises(RemoteLogError) as raised, fetched_log(memory, max_bytes=100):
        pass

    assert str(raised.value) == f"{memory}: larger than the 100 bytes a log behind a URL may have"


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


def test_the_fleet_extra_brings_what_http_urls_need() -> None:
    pyproject = Path(__file__).parents[1] / "pyproject.toml"
    extras = tomllib.loads(pyproject.read_text(encoding="utf-8"))["project"]
    fleet = [Requirement(line) for line in extras["optional-dependencies"]["fleet"]]

    assert [(req.name, req.extras) for req in fleet] == [("fsspec", {"http"})]
