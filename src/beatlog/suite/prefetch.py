"""Fetching logs ahead: a cluster's worker copies the next DTC's log behind a URL into
this machine's cache while it replays one (:mod:`beatlog.suite.remote`), so that
fetching overlaps replaying."""

from __future__ import annotations

import threading

from beatlog.errors import RemoteLogError
from beatlog.suite.remote import Listed, fetched_log

__all__ = ["fetch_ahead", "wait_for"]

_fetching_lock = threading.Lock()
_fetching: dict[str, threading.Thread] = {}
"""The logs this process fetches ahead, by URL."""


def fetch_ahead(url: str, listed: Listed | None = None) -> None:
    """Start copying the log behind ``url`` (which a listing described as ``listed``, if
    given) into this machine's cache in the background, unless this process is already
    at it (:func:`wait_for` waits for it). A log fetched
    ahead by another machine is simply fetched again where it is replayed; one that
    cannot be fetched is left to the DTC's own copy, which says what is wrong."""
    with _fetching_lock:
        if url in _fetching:
            return
        thread = threading.Thread(
            target=_fetch, args=(url, listed), name="beatlog-fetch", daemon=True
        )
        _fetching[url] = thread
        thread.start()


def wait_for(url: str) -> None:
    """Return once this process is no longer fetching ``url`` ahead."""
    with _fetching_lock:
        thread = _fetching.get(url)
    if thread is not None:
        thread.join()


def _fetch(url: str, listed: Listed | None) -> None:
    """Copy the log behind ``url`` into the cache, and forget it is being fetched."""
    try:
        with fetched_log(url, listed=listed):
            pass
    except RemoteLogError:
        pass  # the DTC's own copy says what is wrong
    finally:
        with _fetching_lock:
            del _fetching[url]
