"""Suites on a Dask cluster: ``beatlog test --dask ADDRESS`` (or ``--dask local:N``).

One Dask task per DTC runs :func:`beatlog.suite.runner.run_spec` and sends back its
outcome; outcomes stream back as they complete, to the same progress bar and reports.
Tasks are submitted as outcomes come, two a cluster thread ahead of them, so the files
they ship are held for those DTCs alone. A spec travels with absolute paths to a
cluster of this machine's (``local``); to another, with the files of this machine its
replay reads (:func:`packed`: its baseline, its local log, its project's
``pyproject.toml``), written into a folder of the worker's in the same places
(:func:`unpacked`). A log behind a URL is copied by the worker that replays it, which
also fetches ahead the logs it is likely to replay next. Code is not shipped: a worker
without the system's package makes the DTC an error that says so
(:func:`missing_system`).

A worker that dies while it replays a DTC does not lose the DTC: the scheduler runs it
again on another worker, up to ``distributed.scheduler.allowed-failures``, and the
outcome counts the retries (:class:`WorkerDeaths`); past them the DTC is an error.
Needs ``pip install "beatlog[dask]"``.
"""

from __future__ import annotations

import asyncio
import collections
import dataclasses
import importlib.util
import itertools
import logging
import re
import socket
import tempfile
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from beatlog.baseline.file import expected_path
from beatlog.errors import ClusterError, first_line
from beatlog.log.files import Closing, project_root
from beatlog.project.usercode import importable_near
from beatlog.suite.parallel import longest_first
from beatlog.suite.remote import Listed, fetch_ahead, wait_for
from beatlog.suite.runner import SpecOutcome, Verdict, run_spec
from beatlog.suite.spec import DtcSpec

if TYPE_CHECKING:
    from distributed import Future, LocalCluster

    from beatlog.baseline.policy import SpecOptions

__all__ = [
    "FETCHED_AHEAD",
    "ONE_DTC_PER_THREAD",
    "DaskExecutor",
    "Packed",
    "WorkerDeaths",
    "as_here",
    "fetched_ahead",
    "missing_system",
    "packed",
    "unpacked",
]

ONE_DTC_PER_THREAD = {"distributed.scheduler.worker-saturation": 1.0}
"""The scheduler's setting for DTC suites, and that of the cluster ``local`` starts: a
worker is sent no more DTCs than it has threads, so one that dies takes only the DTCs
it was replaying with it (with Dask's default, 1.1, a worker of one thread also holds
the next DTC, which would count as retried too)."""

_IN_FLIGHT_PER_THREAD = 2
"""How many DTCs a run keeps submitted for each thread of the cluster."""
FETCHED_AHEAD = 4
"""How many DTCs ahead of the one it replays a worker's thread has the URL logs
fetched: enough to hide a request's latency behind replays shorter than it."""
_LOCAL = re.compile(r"local(?::([1-9][0-9]*))?")
_OUTSIDE = "outside"


class DaskExecutor(Closing):
    """A connection to a Dask cluster that runs suites, one task per DTC (an
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
        self._cluster: LocalCluster | None = None
        self._ships = local is None  # a cluster of this machine shares its files
        self._deaths = WorkerDeaths()
        try:
            if local is None:
                _handshake(address)
                self._client = Client(address, set_as_default=False)
            else:
                workers = None if local.group(1) is None else int(local.group(1))
                with dask.config.set(ONE_DTC_PER_THREAD):
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
        """Submit one task per spec and give each outcome to ``done`` as it completes,
        until ``done`` says stop or none is left. On leaving, Ctrl-C included, the tasks
        not complete are cancelled."""
        from distributed import as_completed  # noqa: PLC0415 - with the client's package

        ordered = longest_first(specs)  # the scheduler starts them in this order
        threads = max(1, sum(self._client.nthreads().values()))
        waiting = iter(zip(ordered, fetched_ahead(ordered, threads), strict=True))
        pending: dict[str, tuple[Future[SpecOutcome], DtcSpec]] = {}

        def submit(count: int) -> list[Future[SpecOutcome]]:
            """Submit the next ``count`` DTCs, reading the files they ship only now."""
            chosen = list(itertools.islice(waiting, count))
            if not chosen:
                return []
            keys = [f"dtc-{spec.name}-{uuid.uuid4().hex}" for spec, _ in chosen]
            sent = [
                packed(_absolute(spec)) if self._ships else _absolute(spec) for spec, _ in chosen
            ]
            later = [next_ for _, next_ in chosen]
            futures: list[Future[SpecOutcome]] = self._client.map(  # one message for all
                _replayed, sent, later, options=options, key=keys, pure=False
            )
            for future, (spec, _) in zip(futures, chosen, strict=True):
                pending[str(future.key)] = (future, spec)
            return futures

        completed = as_completed(
            submit(_IN_FLIGHT_PER_THREAD * threads),
            loop=self._client.loop,
            with_results=True,  # gathered as they complete: no round trip a DTC here
            raise_errors=False,
        )
        try:
            for future, result in completed:
                _, spec = pending.pop(str(future.key))
                if done(self._outcome(future, result, spec)):
                    return
                completed.update(submit(1))
        finally:
            self._client.cancel([future for future, _ in pending.values()], force=True)

    def _outcome(self, future: Future[SpecOutcome], result: Any, spec: DtcSpec) -> SpecOutcome:
        """The outcome of a completed task from its ``result`` (a failed task's is
        ``(type, exception, traceback)``, a cancelled one's the exception), told as a
        local run tells it, with the times the DTC was run again because its worker died."""
        from distributed import KilledWorker  # noqa: PLC0415 - with the client's package

        if future.status == "finished":
            return _as_given(result, spec, self._deaths[str(future.key)])
        exc = result[1].with_traceback(result[2]) if isinstance(result, tuple) else result
        if not isinstance(exc, KilledWorker):
            raise exc
        tries = exc.allowed_failures + 1
        problem = f"{tries} workers died while replaying it (a crash, or a machine lost)"
        return SpecOutcome(spec, Verdict.ERROR, None, problem, 0.0, retries=tries - 1)

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


def fetched_ahead(
    ordered: Sequence[DtcSpec], threads: int
) -> list[list[tuple[str, Listed | None]]]:
    """For each DTC in the order run, the URL logs (and what their listing said) its
    task fetches ahead while it replays: those :data:`FETCHED_AHEAD` DTCs further on
    for its thread (as many DTCs on as the cluster has threads), each log by one task
    alone: a thread's first task starts them all, each later one the last."""
    urls = [None if spec.log_url is None else (spec.log_url, spec.listed_log) for spec in ordered]
    ahead: list[list[tuple[str, Listed | None]]] = []
    for index in range(len(ordered)):
        steps = range(1, FETCHED_AHEAD + 1) if index < threads else (FETCHED_AHEAD,)
        later = (index + threads * step for step in steps)
        ahead.append([url for at in later if at < len(urls) and (url := urls[at]) is not None])
    return ahead


def _replayed(
    sent: DtcSpec | Packed, ahead: list[tuple[str, Listed | None]], *, options: SpecOptions
) -> SpecOutcome:
    """On a worker: :func:`run_spec` of the DTC sent, with its files where it was
    packed, while the logs ``ahead``, which this thread likely replays later, are
    fetched into the machine's cache."""
    for url, listed in ahead:
        fetch_ahead(url, listed)
    if isinstance(sent, DtcSpec):
        return _waited(sent, options)
    with (
        tempfile.TemporaryDirectory(prefix="beatlog-dtc-") as name,
        importable_near(sent.spec_file),  # where the worker shares the spec's folder
    ):
        folder = Path(name)
        spec = unpacked(sent, folder)
        problem = missing_system(spec, socket.gethostname())
        if problem is not None:
            return SpecOutcome(spec, Verdict.ERROR, None, problem, 0.0)
        outcome = _waited(spec, options)
    if outcome.error is None:
        return outcome
    return dataclasses.replace(outcome, error=as_here(outcome.error, sent, folder))


def _waited(spec: DtcSpec, options: SpecOptions) -> SpecOutcome:
    """:func:`run_spec`, after the log this process is fetching ahead for the DTC, if it
    is, the time waited for it counted as waiting for storage."""
    asked = time.perf_counter()
    if spec.log_url is not None:
        wait_for(spec.log_url)
    waited = time.perf_counter() - asked
    outcome = run_spec(spec, options)
    if outcome.storage_wait_s is None:
        return outcome
    return dataclasses.replace(outcome, storage_wait_s=outcome.storage_wait_s + waited)


def _absolute(spec: DtcSpec) -> DtcSpec:
    """The spec with absolute paths, for a worker whose working folder is not ours (a
    log behind a URL is named by its URL alone)."""
    log = spec.log if spec.log_url is not None else spec.log.absolute()
    return dataclasses.replace(spec, path=spec.path.absolute(), log=log)


def _as_given(outcome: SpecOutcome, spec: DtcSpec, retries: int) -> SpecOutcome:
    """A worker's outcome with the spec as given here (relative paths stay relative):
    the same log, error, rerun command and baseline as a local run's."""
    sent = _absolute(spec)
    outcome = dataclasses.replace(outcome, spec=spec, retries=retries)
    result = outcome.result
    if result is not None:
        result = dataclasses.replace(result, log=spec.log, reproduce=outcome.reproduce)
    error = outcome.error
    if error is not None:
        for absolute, given in ((sent.log, spec.log), (sent.path, spec.path)):
            error = error.replace(str(absolute), str(given))
    baseline = None if outcome.baseline is None else expected_path(spec.path)
    return dataclasses.replace(outcome, result=result, error=error, baseline=baseline)


@dataclass(frozen=True)
class Packed:
    """A DTC with its paths relative to its project's root, and the files it reads, by
    those paths."""

    spec: DtcSpec
    files: dict[str, bytes]
    root: str
    """The project's root here, where the relative paths start."""
    spec_file: Path | None
    """The spec file here, whose folder and project root the DTC's code also imports
    from where the worker shares them (None for a fleet log)."""


def packed(spec: DtcSpec) -> Packed:
    """``spec`` with the files of this machine its replay reads (its baseline, its log
    if local, its project's ``pyproject.toml``), where they exist; a fleet's log reads
    only its own."""
    folder = spec.path.absolute().parent
    root = project_root(folder) or folder
    files: dict[str, bytes] = {}
    read = [] if spec.spec_file is None else [root / "pyproject.toml", expected_path(spec.path)]
    for path in read if spec.log_url is not None else [*read, spec.log]:
        if path.is_file():
            files[_relative(path, root).as_posix()] = path.read_bytes()
    log = spec.log if spec.log_url is not None else _relative(spec.log, root)
    relative = dataclasses.replace(spec, path=_relative(spec.path, root), log=log)
    here = None if spec.spec_file is None else spec.spec_file.absolute()
    return Packed(relative, files, str(root), here)


def unpacked(shipped: Packed, folder: Path) -> DtcSpec:
    """Write the shipped files into ``folder`` and return the DTC with its paths there."""
    for name, data in shipped.files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    spec = shipped.spec
    log = spec.log if spec.log_url is not None else folder / spec.log
    return dataclasses.replace(spec, path=folder / spec.path, log=log)


def as_here(text: str, shipped: Packed, folder: Path) -> str:
    """``text`` (a message) with the paths of the files unpacked into ``folder`` named
    as they are on the machine that packed them."""
    text = text.replace(f"{folder / _OUTSIDE}", "")
    return text.replace(str(folder), shipped.root)


def missing_system(spec: DtcSpec, where: str) -> str | None:
    """Why the DTC cannot run at ``where`` (a worker): its system's (or perception
    step's) package is not installed there; None where it is, or the log names it."""
    for reference in (spec.system, spec.perception):
        if reference is None:
            continue
        package = reference.partition(":")[0].partition(".")[0]
        if importlib.util.find_spec(package) is None:
            return (
                f"the worker {where} has no package {package!r} ({reference}): "
                "install the system's package on the cluster's workers"
            )
    return None


def _relative(path: Path, root: Path) -> Path:
    """Where ``path`` goes in the worker's folder: its place under the project's root,
    or under ``outside/`` by its absolute path where it lies elsewhere."""
    absolute = path.absolute()
    try:
        return absolute.resolve().relative_to(root.resolve())
    except ValueError:
        return Path(_OUTSIDE, *absolute.parts[1:])
