"""Runs DTC suites: specs replayed here and, with more than one job, in worker processes
as well (:mod:`beatlog.suite.worker`), all cores by default; and splits a suite into
shards for a CI matrix: N jobs that each run ``--shard I/N`` cover every DTC once. Both
spread the DTCs by their logs' recorded cycles, the longest first (a log that cannot be
read cheaply counts 0; its run says what is wrong), or, where a log lies behind a URL,
by every log's size as its listing or filesystem gives it, no log downloaded. A shard
depends only on the specs' paths and these weights, so every job computes the same
split; a size that cannot be had fails it (a job must not guess what others may not).
"""

from __future__ import annotations

import collections
import heapq
import queue
import re
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

from beatlog.baseline.policy import SpecOptions, UpdateMode
from beatlog.errors import OptionError, RemoteLogError
from beatlog.log.files import irregular_file_problem
from beatlog.log.index import recorded_cycles
from beatlog.suite.remote import log_size
from beatlog.suite.runner import SpecOutcome, Verdict, run_spec, suite_auditors
from beatlog.suite.spec import DtcSpec
from beatlog.suite.worker import Worker, WorkerLostError

__all__ = ["Executor", "Shard", "longest_first", "run_suite", "shard", "split"]

Executor = Callable[[Sequence[DtcSpec], SpecOptions, Callable[[SpecOutcome], bool]], None]
"""Runs specs somewhere else than this machine's worker processes (a Dask cluster, see
:class:`beatlog.suite.cluster.DaskExecutor`): each outcome, from :func:`run_spec`, goes
to the callback as it comes, until the callback says stop (returns True)."""


def run_suite(
    specs: Sequence[DtcSpec],
    *,
    jobs: int = 1,
    fail_fast: bool = False,
    update: UpdateMode | str = UpdateMode.NONE,
    audit: bool = False,
    timelines: bool = False,
    on_outcome: Callable[[SpecOutcome], object] | None = None,
    break_at: int | None = None,
    break_on_divergence: bool = False,
    coverage: bool = False,
    executor: Executor | None = None,
) -> list[SpecOutcome]:
    """Run every spec, ``jobs`` at a time, or with ``executor`` (``jobs`` then unused);
    outcomes in spec order, each as :func:`run_spec` gives it with these options.

    With more than one job, this process replays specs too while ``jobs - 1`` worker
    processes start and then take the next spec each as they become free, the longest
    recording first: a suite too small to gain from workers is done before they are
    ready. With ``fail_fast`` the first failure or error stops the run: specs not
    started are not run and the workers are stopped. Break points replay every spec in
    this process.
    """
    update = UpdateMode.parse(update)
    outcomes: dict[str, SpecOutcome] = {}

    def done(outcome: SpecOutcome) -> bool:
        outcomes[outcome.spec.id] = outcome
        if on_outcome is not None:
            on_outcome(outcome)
        return fail_fast and outcome.verdict is not Verdict.PASSED

    options = SpecOptions(update, audit, timelines, break_at, break_on_divergence, coverage)
    breaking = break_at is not None or break_on_divergence
    if breaking and executor is not None:
        raise ValueError("break points stop in this process; they cannot run on an executor")
    workers = 0 if breaking else min(jobs, len(specs)) - 1
    if executor is not None:
        executor(specs, options, done)
    elif workers < 1:
        with suite_auditors(options) as auditors:
            for spec in specs:
                if done(run_spec(spec, options, auditors=auditors)):
                    break
    else:
        _run_with_workers(specs, workers, options, done)
    return [outcomes[spec.id] for spec in specs if spec.id in outcomes]


Answer = SpecOutcome | BaseException
"""What comes back from a worker: an outcome, or why there is none."""


def _run_with_workers(
    specs: Sequence[DtcSpec],
    workers: int,
    options: SpecOptions,
    done: Callable[[SpecOutcome], bool],
) -> None:
    """Run the specs here and in ``workers`` worker processes until ``done`` says stop,
    one thread per worker handing it the next spec. On leaving, Ctrl-C included, the
    specs not started are dropped, the workers are stopped, and the outcomes that had
    come back by then still go to ``done``."""
    pending = collections.deque(longest_first(specs))  # work spread by cycles
    answers: queue.Queue[Answer] = queue.Queue()
    pool: list[Worker] = []
    feeders: list[threading.Thread] = []
    left = len(specs)
    with suite_auditors(options) as auditors:
        try:
            for _ in range(workers):
                pool.append(Worker())
                feeder = threading.Thread(
                    target=_feed, args=(pool[-1], pending, options, answers), daemon=True
                )
                feeder.start()
                feeders.append(feeder)
            while left:
                answer: Answer
                if pending and answers.empty():
                    try:
                        spec = pending.popleft()
                    except IndexError:  # a worker took the last one
                        continue
                    answer = run_spec(spec, options, auditors=auditors)
                else:
                    answer = answers.get()
                left -= 1
                if isinstance(answer, BaseException):
                    raise answer
                if done(answer):
                    return
        finally:
            pending.clear()
            for worker in pool:
                worker.stop()  # all at once: their work unwinds side by side
            for worker in pool:
                worker.close()
            for feeder in feeders:
                feeder.join()
            while not answers.empty():
                answer = answers.get_nowait()
                if isinstance(answer, SpecOutcome):
                    done(answer)


def _feed(
    worker: Worker,
    pending: collections.deque[DtcSpec],
    options: SpecOptions,
    answers: queue.Queue[Answer],
) -> None:
    """Once the worker is ready, hand it the pending specs one at a time until none is
    left; every outcome, or why there is none, goes to ``answers``. A worker that crashes
    while replaying a DTC makes that DTC an error, and its share of the DTCs left goes to
    the other workers and this process."""
    try:
        worker.wait_ready()
        while True:
            try:
                spec = pending.popleft()
            except IndexError:
                return
            try:
                answers.put(worker.run(spec, options))
            except WorkerLostError as exc:  # the DTC's code crashed it: the others run on
                if not worker.stopped:
                    problem = f"{exc} while replaying it (a crash, or the process killed)"
                    answers.put(SpecOutcome(spec, Verdict.ERROR, None, problem, 0.0))
                return
    except BaseException as exc:  # the runner raises it, unless it is leaving anyway
        answers.put(exc)


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
    """The specs in ``count`` shards balanced by recorded cycles, each in path order: no
    shard has more cycles than another by more than the longest recording's.

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
    if any(spec.log_url is not None and spec.log_size is None for spec in specs):
        with ThreadPoolExecutor(_SIZE_REQUESTS) as pool:  # waits, not work: one at a time is slow
            sizes = list(pool.map(lambda spec: _size(spec, strict=strict), specs))
        weights = list(zip(specs, sizes, strict=True))
    elif any(spec.log_url is not None for spec in specs):  # a listing gave every URL's size
        weights = [(spec, _size(spec, strict=strict)) for spec in specs]
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
    """The specs of shard ``index`` of ``count`` (1-based) of :func:`split`. The shards
    past the number of specs are empty, so the split is computed over that many alone:
    a matrix of ``--shard I/1000000`` costs what its suite does.

    :raises RemoteLogError: the size of a log behind a URL cannot be had.
    """
    if not 1 <= index <= count:
        raise ValueError(f"shard {index} of {count}: the index must be from 1 to {count}")
    used = min(count, len(specs))
    return split(specs, used)[index - 1] if index <= used else []
