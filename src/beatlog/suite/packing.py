"""How a suite's DTCs become a cluster's tasks: runs of them in the order run, a big
DTC alone and small ones together, so that a cluster's cost of a task does not swamp
their replays (:func:`tasks`); and which logs behind URLs each task fetches ahead for
those its thread likely replays next (:func:`fetched_ahead`)."""

from __future__ import annotations

import itertools
from collections.abc import Sequence

from beatlog.suite.remote import Listed
from beatlog.suite.spec import DtcSpec

__all__ = [
    "FETCHED_AHEAD",
    "TASKS_PER_THREAD",
    "TASK_BYTES",
    "TASK_BYTES_AT_THE_END",
    "fetched_ahead",
    "tasks",
]

FETCHED_AHEAD = 4
"""How many DTCs ahead of the task it replays a worker's thread has the URL logs fetched,
at least (whole tasks): enough to hide a request's latency behind replays shorter than it."""
TASK_BYTES = 1 << 20
"""The most bytes of logs a task of several DTCs replays; a log this big or bigger is a
task of its own. A task costs a cluster about 10 ms of CPU; a small log replays at about
0.35 ms a KiB: 1 MiB replays for about 350 ms, and a task still ends often enough for
outcomes to stream back."""
TASK_BYTES_AT_THE_END = TASK_BYTES // 4
"""The fewest bytes of logs the last tasks of several DTCs replay, tasks shrinking to
them: about 90 ms of replay, the most a thread waits at the end for another's last."""
TASKS_PER_THREAD = 4
"""The fewest tasks a cluster thread gets where DTCs are packed together: enough that
threads finishing at different times even out, and that all stay busy to the end."""


def tasks(sizes: Sequence[int | None], threads: int) -> list[range]:
    """The DTCs, given by their logs' sizes in bytes in the order run (None: not known),
    as the tasks of a cluster of ``threads`` threads: runs of DTCs in that order, each
    DTC once. The first task of each thread holds one DTC, whose outcome then comes back
    as soon as a replay allows; after them a log of :data:`TASK_BYTES` or more, or of no
    known size, is a task alone, and smaller ones are packed together: no more of them
    than leaves each thread :data:`TASKS_PER_THREAD` tasks, and up to half a thread's
    share of the bytes not yet in a task, at most :data:`TASK_BYTES` and at least
    :data:`TASK_BYTES_AT_THE_END`, so that tasks shrink toward the end and the threads
    finish together."""
    most = max(1, len(sizes) // (threads * TASKS_PER_THREAD))
    weights = [TASK_BYTES if size is None else size for size in sizes]
    left = sum(weights)
    grouped: list[range] = []
    start = carried = 0
    bound = TASK_BYTES
    for index, weight in enumerate(weights):
        full = index - start >= most or carried >= TASK_BYTES or carried + weight > bound
        if index > start and (full or len(grouped) < threads):
            grouped.append(range(start, index))
            left -= carried
            share = left // (2 * threads)
            start, carried, bound = index, 0, max(TASK_BYTES_AT_THE_END, min(TASK_BYTES, share))
        carried += weight
    if start < len(sizes):
        grouped.append(range(start, len(sizes)))
    return grouped


def fetched_ahead(
    grouped: Sequence[Sequence[DtcSpec]], threads: int
) -> list[list[tuple[str, Listed | None]]]:
    """For each task in the order run, the URL logs (and what their listing said) it
    fetches ahead while it replays, each log by one task alone. A thread is taken to
    run every ``threads``-th task: each of its tasks has the logs of its next tasks
    fetched, as many as hold :data:`FETCHED_AHEAD` DTCs; its first one, the logs of its
    own DTCs after the first too."""
    ahead: list[list[tuple[str, Listed | None]]] = [[] for _ in grouped]
    for first in range(min(threads, len(grouped))):
        own = range(first, len(grouped), threads)  # this thread's tasks
        stream = [
            None if spec.log_url is None else (spec.log_url, spec.listed_log)
            for at in own
            for spec in grouped[at]
        ]
        ends = list(itertools.accumulate(len(grouped[at]) for at in own))
        fetched = 1  # the thread's first DTC copies its own log
        for step, at in enumerate(own):
            wanted = ends[step] + FETCHED_AHEAD
            until = next((end for end in ends[step + 1 :] if end >= wanted), len(stream))
            ahead[at] = [url for url in stream[fetched:until] if url is not None]
            fetched = until
    return ahead
