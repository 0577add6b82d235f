"""Runs DTC suites: specs replayed here and, with more than one job, in worker processes
as well (:mod:`beatlog.suite.worker`); all cores by default. Each spec runs with
:func:`~beatlog.suite.runner.run_spec`."""

from __future__ import annotations

import collections
import queue
import threading
from collections.abc import Callable, Sequence

from beatlog.baseline.policy import SpecOptions, UpdateMode
from beatlog.suite.runner import SpecOutcome, Verdict, run_spec, suite_auditors
from beatlog.suite.sharding import longest_first
from beatlog.suite.spec import DtcSpec
from beatlog.suite.worker import Worker

__all__ = ["Executor", "run_suite"]

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
    """Run the specs here and in ``workers`` worker processes until ``done`` says stop.

    One thread per worker hands it the next spec once it is ready and free. On leaving,
    Ctrl-C included, the specs not started are dropped, the workers are stopped (see
    :meth:`Worker.stop`), and the outcomes that had come back by then are still given
    to ``done``.
    """
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
    left; every outcome, or why there is none, goes to ``answers``."""
    try:
        worker.wait_ready()
        while True:
            try:
                spec = pending.popleft()
            except IndexError:
                return
            answers.put(worker.run(spec, options))
    except BaseException as exc:  # the runner raises it, unless it is leaving anyway
        answers.put(exc)
