"""Splits a suite into shards for a CI matrix: N jobs that each run ``--shard I/N`` cover
every DTC exactly once, with about the same number of recorded cycles each.

The split depends only on the specs' paths and their logs' cycle counts, so every job
of the matrix computes the same one: specs are sorted by path, then given, the longest
recording first, to the shard with the fewest cycles so far (the first such shard on a
tie). A log whose cycle count cannot be read cheaply (one cut off, damaged or missing)
counts 0 cycles: it still lands in exactly one shard, and its run says what is wrong.

When a log lies behind a URL, every log of the suite weighs its size in bytes instead:
the size the listing of a fleet's logs gave, or, for a spec's log, the size its
filesystem lists (:func:`beatlog.suite.remote.log_size`, asked for all such logs at once):
no log is downloaded to plan the work, and a fleet's is planned with no request per
log. A size that cannot be had fails the split (a job must not guess what the others
may not), and counts 0 where only the order of the work depends on it.
"""

from __future__ import annotations

import heapq
import re
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

from beatlog.errors import OptionError, RemoteLogError
from beatlog.log.files import irregular_file_problem
from beatlog.log.index import recorded_cycles
from beatlog.suite.remote import log_size
from beatlog.suite.spec import DtcSpec

__all__ = ["Shard", "longest_first", "shard", "split"]

_SIZE_REQUESTS = 16
"""How many sizes of logs behind URLs are asked for at once, where no listing gave them."""


@dataclass(frozen=True)
class Shard:
    """Shard ``index`` of ``count`` (1-based, as in ``--shard 2/4``)."""

    index: int
    count: int

    @classmethod
    def parse(cls, text: str) -> Shard:
        """The shard written ``I/N``; anything else raises :class:`OptionError`."""
        match = re.fullmatch(r"\s*(\d+)\s*/\s*(\d+)\s*", text)
        if match is None:
            raise OptionError(f"expected a shard I/N such as 2/4, got {text!r}")
        index, count = int(match[1]), int(match[2])
        if count < 1:
            raise OptionError(f"shard {text!r}: N must be at least 1")
        if not 1 <= index <= count:
            raise OptionError(f"shard {text!r}: I must be from 1 to {count}")
        return cls(index, count)

    def __str__(self) -> str:
        return f"{self.index}/{self.count}"


def split(specs: Sequence[DtcSpec], count: int) -> list[list[DtcSpec]]:
    """The specs in ``count`` shards balanced by recorded cycles, each in path order.

    No shard has more cycles than another by more than the longest recording's.

    :raises RemoteLogError: the size of a log behind a URL cannot be had.
    """
    if count < 1:
        raise ValueError(f"a suite splits into at least 1 shard, not {count}")
    shards: list[list[DtcSpec]] = [[] for _ in range(count)]
    loads = [(0, index) for index in range(count)]
    for spec, weight in _weighed(sorted(specs, key=lambda spec: spec.path), strict=True):
        load, index = heapq.heappop(loads)
        shards[index].append(spec)
        heapq.heappush(loads, (load + weight, index))
    return [sorted(chosen, key=lambda spec: spec.path) for chosen in shards]


def longest_first(specs: Sequence[DtcSpec]) -> list[DtcSpec]:
    """The specs by recorded cycles, the longest first (in the order given on a tie):
    the order in which a pool of workers that each take the next one finishes soonest."""
    return [spec for spec, _ in _weighed(specs, strict=False)]


def _weighed(specs: Sequence[DtcSpec], *, strict: bool) -> list[tuple[DtcSpec, int]]:
    """Each spec with its log's recorded cycles (0 where they cannot be read cheaply),
    or with its log's size when one lies behind a URL, the longest first; a stable
    sort, so ties keep their order. ``strict``: a size that cannot be had raises."""
    if any(spec.log_url is not None for spec in specs):
        with ThreadPoolExecutor(_SIZE_REQUESTS) as pool:  # waits, not work: one at a time is slow
            sizes = list(pool.map(lambda spec: _size(spec, strict=strict), specs))
        weights = list(zip(specs, sizes, strict=True))
    else:
        weights = [(spec, recorded_cycles(spec.log) or 0) for spec in specs]
    return sorted(weights, key=lambda weighed: -weighed[1])


def _size(spec: DtcSpec, *, strict: bool) -> int:
    """The size in bytes of the spec's log, here or behind its URL; 0 where unknown."""
    if spec.log_url is None:
        return spec.log.stat().st_size if irregular_file_problem(spec.log) is None else 0
    if spec.log_size is not None:
        return spec.log_size
    try:
        return log_size(spec.log_url) or 0
    except RemoteLogError:
        if strict:
            raise
        return 0


def shard(specs: Sequence[DtcSpec], index: int, count: int) -> list[DtcSpec]:
    """The specs of shard ``index`` of ``count`` (1-based) of :func:`split`.

    With more shards than specs, those past the number of specs are empty (the first
    shard with nothing yet always takes the next spec), so the split is computed over
    that many alone: a matrix of ``--shard I/1000000`` costs what its suite does.

    :raises RemoteLogError: the size of a log behind a URL cannot be had.
    """
    if not 1 <= index <= count:
        raise ValueError(f"shard {index} of {count}: the index must be from 1 to {count}")
    used = min(count, len(specs))
    return split(specs, used)[index - 1] if index <= used else []
