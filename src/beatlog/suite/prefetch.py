"""Logs behind URLs fetched ahead: a cluster's worker copies the log of a DTC it is
likely to replay next into its machine's cache of logs (:mod:`beatlog.suite.log_cache`) in a
background thread while it replays the current one, so that replaying waits on storage
as little as it can.

A log being fetched ahead by this process is waited for, never downloaded twice; one
fetched ahead by another machine is simply fetched again where it is replayed. A log
that cannot be fetched ahead is left to the DTC's own copy, which says what is wrong.
"""

from __future__ import annotations

import threading

from beatlog.errors import RemoteLogError
from beatlog.suite.remote import fetched_log

__all__ = ["fetch_ahead", "wait_for"]

_lock = threading.Lock()
_fetching: dict[str, threading.Thread] = {}


def fetch_ahead(url: str) -> None:
    """Start copying the log behind ``url`` into this machine's cache in the background,
    unless this process is already at it."""
    with _lock:
        if url in _fetching:
            return
        thread = threading.Thread(target=_fetch, args=(url,), name="beatlog-fetch", daemon=True)
        _fetching[url] = thread
        thread.start()


def wait_for(url: str) -> None:
    """Return once this process is no longer fetching ``url`` ahead."""
    with _lock:
        thread = _fetching.get(url)
    if thread is not None:
        thread.join()


def _fetch(url: str) -> None:
    """Copy the log behind ``url`` into the cache, and forget it is being fetched."""
    try:
        with fetched_log(url):
            pass
    except RemoteLogError:
        pass  # the DTC's own copy says what is wrong
    finally:
        with _lock:
            del _fetching[url]
