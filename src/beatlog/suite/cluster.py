"""Suites on a Dask cluster: ``beatlog test --dask ADDRESS`` (or ``--dask local:N``).

Each Dask task runs :func:`beatlog.suite.runner.run_spec` for a few DTCs in the order
run (:func:`tasks`: a big DTC alone, small ones together, so that a cluster's cost of a
task does not swamp their replays) and sends back their outcomes; outcomes stream back
as tasks complete, each DTC's to the same progress bar and reports. Tasks are submitted
as outcomes come, one a cluster thread, so the files they ship
(:mod:`beatlog.suite.shipping`) are held for those DTCs alone, and a worker holds no
task but the one each of its threads runs. A log behind a URL is
copied by the worker that replays it, which also fetches ahead the logs it is likely to
replay next (:func:`fetched_ahead`).

A worker that dies while it replays a DTC does not lose the DTC: the scheduler runs its
task again on another worker, up to ``distributed.scheduler.allowed-failures``, and the
outcome counts the retries (:class:`WorkerDeaths`); past them a task of several DTCs is
run again one DTC a task, so that only the DTC that kills its workers is an error. A
cluster left with no workers at all (every one lost and none restarted, or none ever
joined) for :data:`NO_WORKERS_S` ends the run with a :class:`ClusterError`, after the
outcomes that came before: its tasks would wait for a worker without end.
Needs ``pip install "beatlog[dask]"``.
"""

from __future__ import annotations

import asyncio
import collections
import itertools
import logging
import re
import threading
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from beatlog.errors import ClusterError, first_line
from beatlog.log.files import Closing
from beatlog.suite.parallel import longest_first
from beatlog.suite.remote import Listed
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.shipping import absolute, as_given, packed, replayed
from beatlog.suite.spec import DtcSpec

if TYPE_CHECKING:
    from distributed import Future, LocalCluster

    from beatlog.baseline.policy import SpecOptions

__all__ = [
    "FETCHED_AHEAD",
    "NO_WORKERS_S",
    "TASKS_PER_THREAD",
    "TASK_BYTES",
    "UNPROFILED",
    "DaskExecutor",
    "WorkerDeaths",
    "fetched_ahead",
    "tasks",
]

UNPROFILED = {"distributed.worker.profile.enabled": False}
"""The workers' setting of the cluster ``local`` starts, worth a cluster's own too: Dask's
profiler, sampling a worker's threads every 10 ms for its dashboard, costs 0.5-0.9 ms of
CPU a DTC of a 3-s rover log, whose replay takes 3 ms."""

NO_WORKERS_S = 60.0
"""How long a run waits on a cluster with no workers before it ends: long enough for
a nanny to restart a worker that died, or for a scheduler's workers to join it."""
_WORKERS_ASKED_EVERY_S = 1.0
_ANSWER_S = 5.0
FETCHED_AHEAD = 4
"""How many DTCs ahead of the task it replays a worker's thread has the URL logs fetched,
at least (whole tasks): enough to hide a request's latency behind replays shorter than it."""
TASK_BYTES = 1 << 20
"""The most bytes of logs a task of several DTCs replays; a log this big or bigger is a
task of its own. A task costs a cluster about 10 ms of CPU, and its thread waits for the
next (one a thread is submitted) for as long; a small log replays at about 0.35 ms a KiB:
1 MiB replays for about 350 ms, and a task still ends often enough for outcomes to
stream back and threads to finish together."""
TASKS_PER_THREAD = 4
"""The fewest tasks a cluster thread gets where DTCs are packed together: enough that
threads finishing at different times even out, and that all stay busy to the end."""
_LOCAL = re.compile(r"local(?::([1-9][0-9]*))?")


class DaskExecutor(Closing):
    """A connection to a Dask cluster that runs suites, a few DTCs a task (an
    :data:`~beatlog.suite.parallel.Executor`): a scheduler's ``address``
    (``tcp://host:8786``), or ``local`` (``local:N``) for worker processes on this
    machine, one per core (N), closed with the executor.

    :raises ClusterError: the address is not one, or no scheduler answers there within
        ``distributed.comm.timeouts.connect``.
    """

    def __init__(self, address: str) -> None:
        try:
            import dask  # noqa: PLC0415 - an optional extra
            from distributed import Client, LocalCluster  # noqa: PLC0415
        except ModuleNotFoundError:
            raise ClusterError(
                f'--dask {address}: needs dask.distributed (pip install "beatlog[dask]")'
            ) from None
        local = _LOCAL.fullmatch(address)
        if local is None and address.startswith("local"):
            raise ClusterError(
                f"--dask {address}: expected local, or local:N with N worker processes from 1"
            )
        self._address = address
        self._cluster: LocalCluster | None = None
        self._ships = local is None  # a cluster of this machine shares its files
        self._deaths = WorkerDeaths()
        try:
            if local is None:
                _handshake(address)
                self._client = Client(address, set_as_default=False)
            else:
                workers = None if local.group(1) is None else int(local.group(1))
                with dask.config.set(UNPROFILED):
                    self._cluster = LocalCluster(
                        n_workers=workers,
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=":0",  # no fixed port: runs side by side never clash
                        silence_logs=logging.CRITICAL,
                    )
                self._client = Client(self._cluster, set_as_default=False)
            self._client.subscribe_topic("all", self._deaths.seen)
        except (OSError, ValueError) as exc:  # TimeoutError is an OSError
            self.close()
            raise ClusterError(
                f"--dask {address}: cannot reach the cluster: {first_line(exc)}"
            ) from None

    def __call__(
        self,
        specs: Sequence[DtcSpec],
        options: SpecOptions,
        done: Callable[[SpecOutcome], bool],
    ) -> None:
        """Submit the specs in :func:`tasks` and give each outcome to ``done`` as its task
        completes, until ``done`` says stop or none is left. On leaving, Ctrl-C included,
        the tasks not complete are cancelled."""
        from distributed import as_completed  # noqa: PLC0415 - with the client's package

        ordered = longest_first(specs)  # the scheduler starts them in this order
        threads = max(1, sum(self._client.nthreads().values()))
        grouped = [
            [ordered[index] for index in task]
            for task in tasks([_log_bytes(spec) for spec in ordered], threads)
        ]
        ahead = fetched_ahead(grouped, threads)
        waiting = collections.deque(map(_Task, grouped, ahead))
        pending: dict[str, tuple[Future[list[SpecOutcome]], _Task]] = {}
        guard = threading.Lock()  # of pending and lost, which the lookout sets
        ended, lost = threading.Event(), threading.Event()

        def waited(*, losing: bool = False) -> list[Future[list[SpecOutcome]]]:
            """The futures submitted whose outcomes have not come; ``losing``, with the
            cluster marked lost, so that no more are submitted."""
            with guard:
                if losing:
                    lost.set()
                return [future for future, _ in pending.values()]

        def submit(count: int) -> list[Future[list[SpecOutcome]]]:
            """Submit the next ``count`` tasks, reading the files they ship only now."""
            chosen = [waiting.popleft() for _ in range(min(count, len(waiting)))]
            keys = [f"dtc-{task.specs[0].name}-{uuid.uuid4().hex}" for task in chosen]
            sent = [
                [packed(absolute(spec)) if self._ships else absolute(spec) for spec in task.specs]
                for task in chosen
            ]
            with guard:
                if not chosen or lost.is_set():  # the cluster has no workers: nothing more
                    return []
                futures: list[Future[list[SpecOutcome]]] = self._client.map(  # one message
                    replayed,
                    sent,
                    [task.ahead for task in chosen],
                    options=options,
                    key=keys,
                    pure=False,
                )
                for future, task in zip(futures, chosen, strict=True):
                    pending[str(future.key)] = (future, task)
            return futures

        completed = as_completed(
            # One task a thread, the next as each completes: Dask sends a worker every
            # task it gets at once, and one that a DTC kills takes those it holds with it.
            submit(threads),
            loop=self._client.loop,
            with_results=True,  # gathered as they complete: no round trip a task here
            raise_errors=False,
        )
        told = 0
        lookout = threading.Thread(
            target=self._look_out,
            args=(waited, ended),
            name="beatlog-lookout",
            daemon=True,
        )
        lookout.start()
        try:
            for future, result in completed:
                with guard:
                    _, task = pending.pop(str(future.key))
                if lost.is_set() and future.status != "finished":
                    continue  # cancelled by the lookout: the outcomes that came still count
                outcomes = self._outcomes(future, result, task)
                future.release()  # now, not as the next completes: a worker lost meanwhile
                # would have the scheduler run the task again for a result no one wants
                if isinstance(outcomes, int):  # its workers died: its DTCs again, one a task
                    waiting.extendleft(_Task([s], [], outcomes) for s in reversed(task.specs))
                completed.update(submit(1))  # before the outcomes: the thread waits for it
                for outcome in () if isinstance(outcomes, int) else outcomes:
                    told += 1
                    if done(outcome):
                        return
            if lost.is_set() and told < len(specs):
                raise ClusterError(
                    f"--dask {self._address}: the cluster has had no workers for "
                    f"{NO_WORKERS_S:g} s (all lost, none restarted): "
                    f"{len(specs) - told} of {len(specs)} DTCs not run"
                )
        finally:
            ended.set()
            lookout.join()
            self._client.cancel(waited(), force=True)

    def _look_out(self, waited: Callable[..., list[Future[Any]]], ended: threading.Event) -> None:
        """Until ``ended``, ask the cluster every second how many workers it has; once it
        has had none for :data:`NO_WORKERS_S`, cancel the futures ``waited(losing=True)``
        gives, which then come back cancelled. A scheduler that does not answer within a
        few seconds counts as having none."""
        since = time.monotonic()
        while not ended.wait(_WORKERS_ASKED_EVERY_S):
            try:
                workers = bool(self._client.nthreads(callback_timeout=_ANSWER_S))
            except Exception:  # Dask's errors share no base: no answer, none for this run
                workers = False
            if workers:
                since = time.monotonic()
            elif time.monotonic() - since >= NO_WORKERS_S:
                self._client.cancel(waited(losing=True), force=True)
                return

    def _outcomes(
        self, future: Future[list[SpecOutcome]], result: Any, task: _Task
    ) -> list[SpecOutcome] | int:
        """The outcomes of a completed task from its ``result`` (a failed task's is
        ``(type, exception, traceback)``, a cancelled one's the exception), told as a
        local run tells them, with the times each DTC was run again because its worker
        died; for a task of several DTCs whose workers kept dying, how many died, its
        DTCs to be run again one a task."""
        from distributed import KilledWorker  # noqa: PLC0415 - with the client's package

        if future.status == "finished":
            deaths = task.deaths + self._deaths[str(future.key)]
            return [
                as_given(outcome, spec, deaths)
                for outcome, spec in zip(result, task.specs, strict=True)
            ]
        exc = result[1].with_traceback(result[2]) if isinstance(result, tuple) else result
        if not isinstance(exc, KilledWorker):
            raise exc
        died = task.deaths + exc.allowed_failures + 1
        if len(task.specs) > 1:
            return died
        problem = f"{died} workers died while replaying it (a crash, or a machine lost)"
        return [SpecOutcome(task.specs[0], Verdict.ERROR, None, problem, 0.0, retries=died - 1)]

    def close(self) -> None:
        """Close the connection, and the local cluster if this executor started one."""
        client = getattr(self, "_client", None)
        if client is not None:
            if client.status == "running":  # or the scheduler tells it of its own closing
                client.unsubscribe_topic("all")
            client.close()
        if self._cluster is not None:
            self._cluster.close()


class WorkerDeaths(collections.Counter[str]):
    """How many workers died while running each task, by its key, counted from the
    scheduler's events of the topic ``all`` as the scheduler counts them (a task's
    ``suspicious``): a worker removed unexpectedly counts once for each task it was
    running. The scheduler sends the event before it runs the task again, on the same
    stream as the task's result, so a result always finds its count."""

    def seen(self, event: tuple[float, Any]) -> None:
        """Take one event ``(time, message)`` of the topic ``all``."""
        _, message = event
        removed = isinstance(message, dict) and message.get("action") == "remove-worker"
        if removed and not message.get("expected"):  # not retired nor closed on purpose
            self.update(str(key) for key in message.get("processing-tasks", ()))


def _handshake(address: str) -> None:
    """Connect to ``address`` and exchange Dask's handshake within
    ``distributed.comm.timeouts.connect``: a client's own connection waits for it
    without end, so a server that is not a Dask scheduler would hang the run.

    :raises ClusterError: no scheduler answers there in time, or what answers is not one.
    """
    import dask  # noqa: PLC0415 - an optional extra
    from dask.utils import parse_timedelta  # noqa: PLC0415
    from distributed.comm.core import connect  # noqa: PLC0415

    timeout = parse_timedelta(dask.config.get("distributed.comm.timeouts.connect"), "seconds")

    async def exchange() -> None:
        comm = await connect(address, timeout=timeout)
        await comm.close()

    try:
        asyncio.run(asyncio.wait_for(exchange(), timeout))
    except TimeoutError:  # before OSError, of which it is one
        problem = f"no Dask scheduler answered there within {timeout:g} s"
    except (OSError, ValueError) as exc:  # no connection, or no address
        problem = first_line(exc)
    except Exception as exc:  # what a server that is not Dask's sends fails to decode anyhow
        problem = f"what answers there is not a Dask scheduler ({type(exc).__name__})"
    else:
        return
    raise ClusterError(f"--dask {address}: cannot reach the cluster: {problem}")


@dataclass(frozen=True)
class _Task:
    """The DTCs of one task, in the order run, with the URL logs it fetches ahead for
    later tasks, and how many workers died while running these DTCs in an earlier task."""

    specs: list[DtcSpec]
    ahead: list[tuple[str, Listed | None]]
    deaths: int = 0


def tasks(sizes: Sequence[int | None], threads: int) -> list[range]:
    """The DTCs, given by their logs' sizes in bytes in the order run (None: not known),
    as the tasks of a cluster of ``threads`` threads: runs of DTCs in that order, each
    DTC once. The first task of each thread holds one DTC, whose outcome then comes back
    as soon as a replay allows; after them a log of :data:`TASK_BYTES` or more, or of no
    known size, is a task alone, and smaller ones are packed together up to that many
    bytes, and no more of them than leaves each thread :data:`TASKS_PER_THREAD` tasks."""
    most = max(1, len(sizes) // (threads * TASKS_PER_THREAD))
    grouped: list[range] = []
    start = carried = 0
    for index, size in enumerate(sizes):
        weight = TASK_BYTES if size is None else size
        full = index - start >= most or carried >= TASK_BYTES or carried + weight > TASK_BYTES
        if index > start and (full or len(grouped) < threads):
            grouped.append(range(start, index))
            start, carried = index, 0
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


def _log_bytes(spec: DtcSpec) -> int | None:
    """The size of the spec's log as its listing or this machine's filesystem gives it,
    nothing asked of a storage; None where neither does."""
    if spec.log_url is not None:
        return spec.log_size
    try:
        return spec.log.stat().st_size
    except OSError:
        return None
