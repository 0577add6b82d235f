"""Suites on a Dask cluster: ``beatlog test --dask ADDRESS`` (or ``--dask local:N``).

Each Dask task runs :func:`beatlog.suite.runner.run_spec` for a few DTCs in the order
run (:mod:`beatlog.suite.packing`) and sends back their outcomes; outcomes stream back as
tasks complete, each DTC's to the same progress bar and reports. Tasks are submitted as
tasks end, one a cluster thread (of the workers there are: a worker that joins during a
run gets tasks of it), so the files they ship (:mod:`beatlog.suite.shipping`) are held
for those DTCs alone, and a worker holds no task but the one each of its threads runs.
A log behind a URL is copied by the worker that replays it, which also fetches ahead the
logs it is likely to replay next.

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
from beatlog.project.interpreters import ctrl_c_deferred
from beatlog.suite.packing import fetched_ahead, tasks
from beatlog.suite.parallel import longest_first
from beatlog.suite.remote import Listed
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.shipping import Packed, absolute, as_given, packed, received, replayed, shipped
from beatlog.suite.spec import DtcSpec

if TYPE_CHECKING:
    from distributed import Future, LocalCluster

    from beatlog.baseline.policy import SpecOptions

__all__ = [
    "CLUSTER_SETTINGS",
    "NO_WORKERS_S",
    "THREADS_ASKED_EVERY_S",
    "DaskExecutor",
    "WorkerDeaths",
]

CLUSTER_SETTINGS = {
    "distributed.worker.profile.enabled": False,
    "distributed.scheduler.worker-saturation": 1.0,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.admin.system-monitor.disk": False,
}
"""The settings of the cluster ``local`` starts, worth a cluster's own too. The profiler
(every 10 ms) costs 0.5-0.9 ms of CPU a DTC of a 3-s rover log, which replays in 3 ms; the
event-loop check every 20 ms and dashboard samples every 0.5 s cost each process 13-40 ms
a second. A saturation of 1 gives a worker no task beyond one a thread, also while
another restarts (Dask's 1.1 gives a worker of one thread two): a DTC that kills its
worker takes no waiting task with it."""

NO_WORKERS_S = 60.0
"""How long a run waits on a cluster with no workers before it ends: long enough for
a nanny to restart a worker that died, or for a scheduler's workers to join it."""
THREADS_ASKED_EVERY_S = 1.0
"""How often a run asks the cluster how many threads its workers have: a worker that
joins gets tasks from the next one that ends after."""
_ANSWER_S = 5.0
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
        self._threads = self._most_threads = 1  # when the lookout last asked; the most
        try:
            if local is None:
                _handshake(address)
                self._client = Client(address, set_as_default=False)
            else:
                workers = None if local.group(1) is None else int(local.group(1))
                with dask.config.set(CLUSTER_SETTINGS), ctrl_c_deferred():
                    self._cluster = LocalCluster(
                        n_workers=workers,
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=":0",  # no fixed port: runs side by side never clash
                        silence_logs=logging.CRITICAL,
                    )
                self._client = Client(self._cluster, set_as_default=False)
            self._client.subscribe_topic("all", self._deaths.seen)
        except BaseException as exc:  # Ctrl-C too: what was started is stopped
            self.close()
            if isinstance(exc, OSError | ValueError):  # TimeoutError is an OSError
                problem = f"cannot reach the cluster: {first_line(exc)}"
                raise ClusterError(f"--dask {address}: {problem}") from None
            raise

    def __call__(
        self,
        specs: Sequence[DtcSpec],
        options: SpecOptions,
        done: Callable[[SpecOutcome], bool],
    ) -> None:
        """Submit the specs in :func:`~beatlog.suite.packing.tasks` and give each outcome to
        ``done`` as its task completes, until ``done`` says stop or none is left. On
        leaving, Ctrl-C included, the tasks not complete are cancelled."""
        from distributed import as_completed  # noqa: PLC0415 - with the client's package

        ordered = longest_first(specs)  # the scheduler starts them in this order
        threads = self._threads = self._most_threads = max(1, sum(self._client.nthreads().values()))
        grouped = [
            [ordered[index] for index in task]
            for task in tasks([_log_bytes(spec) for spec in ordered], threads)
        ]
        waiting = collections.deque(map(_Task, grouped, fetched_ahead(grouped, threads)))
        pending: dict[str, tuple[Future[bytes], _Task]] = {}
        guard = threading.Lock()  # of pending and lost, which the lookout sets
        ended, lost = threading.Event(), threading.Event()

        def waited(*, losing: bool = False) -> list[Future[bytes]]:
            """The futures submitted whose outcomes have not come; ``losing``, with the
            cluster marked lost, so that no more are submitted."""
            with guard:
                if losing:
                    lost.set()
                return [future for future, _ in pending.values()]

        def submit(count: int) -> list[Future[bytes]]:
            """Submit the next ``count`` tasks, reading the files they ship only now."""
            chosen = [waiting.popleft() for _ in range(min(count, len(waiting)))]
            keys = [f"dtc-{task.specs[0].name}-{uuid.uuid4().hex}" for task in chosen]
            sent = [shipped(list(map(self._sent, task.specs)), task.ahead) for task in chosen]
            with guard:
                if not chosen or lost.is_set():  # the cluster has no workers: nothing more
                    return []
                futures: list[Future[bytes]] = self._client.map(  # one message
                    replayed,
                    sent,
                    options=options,
                    key=keys,
                    pure=False,
                )
                for future, task in zip(futures, chosen, strict=True):
                    pending[str(future.key)] = (future, task)
            return futures

        # One task a thread, the next as each ends: Dask sends a worker every task it
        # gets at once, and one that a DTC kills takes those it holds with it. A task's end
        # is heard at once, its outcomes fetched after the next task is submitted: from a
        # worker busy with that one they come 50-150 ms later.
        completed = as_completed(submit(threads), loop=self._client.loop)
        replaced: set[str] = set()  # the tasks whose thread has its next
        told = 0
        lookout = threading.Thread(
            target=self._look_out,
            args=(waited, ended),
            name="beatlog-lookout",
            daemon=True,
        )
        lookout.start()
        try:
            for batch in completed.batches():
                with guard:
                    ran = [pending[str(future.key)][1] for future in batch]
                died = list(map(self._died, batch, ran))
                waiting.extendleft(reversed(_one_a_task(ran, died)))  # run first
                fresh = {str(future.key) for future in batch} - replaced
                completed.update(submit(len(fresh) + self._joined()))  # before the outcomes
                replaced |= fresh
                outcomes, again = self._outcomes(batch, ran, died)
                completed.update(again)  # a worker died holding their outcomes: wait again
                for outcome in outcomes:
                    told += 1
                    if done(outcome):
                        return
                with guard:
                    for future in set(batch) - set(again):
                        del pending[str(future.key)]
                        future.release()  # now, not as the next completes: a worker lost
                        # would have the scheduler run the task again for no one
            if told < len(specs):  # never a pass: a DTC was not run
                raise self._not_run(len(specs) - told, len(specs), lost=lost.is_set())
        finally:
            ended.set()
            lookout.join()
            self._client.cancel(waited(), force=True)

    def _sent(self, spec: DtcSpec) -> DtcSpec | Packed:
        """The spec as its worker gets it: with absolute paths, and with the files it
        reads where the cluster is not of this machine."""
        return packed(absolute(spec)) if self._ships else absolute(spec)

    def _not_run(self, missing: int, total: int, *, lost: bool) -> ClusterError:
        """The error of a run that ended with ``missing`` of its ``total`` DTCs not run:
        the cluster ``lost`` every worker, or their tasks were cancelled on it."""
        why = (
            f"the cluster has had no workers for {NO_WORKERS_S:g} s (all lost, none restarted)"
            if lost
            else "their tasks were cancelled on the cluster (by another client, or a "
            "scheduler that restarted)"
        )
        return ClusterError(f"--dask {self._address}: {why}: {missing} of {total} DTCs not run")

    def _look_out(self, waited: Callable[..., list[Future[Any]]], ended: threading.Event) -> None:
        """Until ``ended``, ask the cluster every second how many threads its workers have,
        for the workers that join (:meth:`_joined`); once it has had no workers for
        :data:`NO_WORKERS_S`, cancel the futures ``waited(losing=True)`` gives, which then
        come back cancelled. A scheduler that does not answer within a few seconds counts
        as having none."""
        since = time.monotonic()
        while not ended.wait(THREADS_ASKED_EVERY_S):
            try:
                self._threads = sum(self._client.nthreads(callback_timeout=_ANSWER_S).values())
            except Exception:  # Dask's errors share no base: no answer, none for this run
                self._threads = 0
            if self._threads:
                since = time.monotonic()
            elif time.monotonic() - since >= NO_WORKERS_S:
                self._client.cancel(waited(losing=True), force=True)
                return

    def _joined(self) -> int:
        """How many threads the cluster has gained past the most it had before, for as
        many more tasks: a worker that joins during a run gets tasks of it. A worker that
        dies or leaves changes nothing: the workers left, or one restarted, take its task."""
        joined = max(0, self._threads - self._most_threads)
        self._most_threads += joined
        return joined

    def _died(self, future: Future[bytes], task: _Task) -> int:
        """How many workers died while replaying the DTCs of a task that ended, in all,
        where its last ones did (past ``allowed-failures``); 0 where it did not fail, or
        was cancelled (the cluster lost).

        :raises Exception: what the task raised, a worker's death aside."""
        from distributed import KilledWorker  # noqa: PLC0415 - with the client's package

        if future.status != "error":
            return 0
        exc = future.exception()
        if not isinstance(exc, KilledWorker):
            raise exc.with_traceback(future.traceback())
        return task.deaths + exc.allowed_failures + 1

    def _outcomes(
        self, batch: list[Future[bytes]], ran: list[_Task], died: list[int]
    ) -> tuple[list[SpecOutcome], list[Future[bytes]]]:
        """The outcomes of the tasks of ``batch`` (the tasks ``ran``, whose workers
        ``died``), fetched from their workers in one round trip, told as a local run tells
        them, with the times each DTC was run again because its worker died; an error for a
        DTC alone whose workers kept dying. None of a batch the lookout cancelled; and the
        futures to wait for again where a worker holding outcomes died before they were
        fetched, and the task run again failed."""
        from distributed import CancelledError  # noqa: PLC0415 - with the client's package

        fetched = [future for future in batch if future.status not in ("error", "cancelled")]
        try:
            results, again = dict(zip(fetched, self._client.gather(fetched), strict=True)), []
        except CancelledError:  # the cluster was lost meanwhile
            return [], []
        except Exception:  # Dask's errors share no base: one of them failed on its way
            results, again = {}, fetched
        outcomes: list[SpecOutcome] = []
        for future, task, deaths in zip(batch, ran, died, strict=True):
            if future in results:
                retries = task.deaths + self._deaths[str(future.key)]
                outcomes += [
                    as_given(outcome, retries) for outcome in received(results[future], task.specs)
                ]
            elif deaths and len(task.specs) == 1:
                workers = f"{deaths} worker{'' if deaths == 1 else 's'}"
                problem = f"{workers} died while replaying it (a crash, or a machine lost)"
                spec = task.specs[0]
                outcomes.append(
                    SpecOutcome(spec, Verdict.ERROR, None, problem, 0.0, retries=deaths - 1)
                )
        return outcomes, again

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


def _one_a_task(ran: list[_Task], died: list[int]) -> list[_Task]:
    """The DTCs of the tasks ``ran`` of several DTCs whose workers kept dying (``died``
    times in all), each a task of its own, to be run again."""
    return [
        _Task([spec], [], deaths)
        for task, deaths in zip(ran, died, strict=True)
        if deaths and len(task.specs) > 1
        for spec in task.specs
    ]


def _log_bytes(spec: DtcSpec) -> int | None:
    """The size of the spec's log as its listing or this machine's filesystem gives it,
    nothing asked of a storage; None where neither does."""
    if spec.log_url is not None:
        return spec.log_size
    try:
        return spec.log.stat().st_size
    except OSError:
        return None
