"""Fetching logs ahead: in the background, into the machine's cache, a log at most once."""

from __future__ import annotations

from beatlog.suite.prefetch import fetch_ahead, wait_for
from beatlog.suite.remote import Listed, fetched_log
from tests.served import LogServer


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
