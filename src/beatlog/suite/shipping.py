"""What a DTC takes to a Dask worker, and how the worker replays it.

A spec travels with absolute paths to a cluster of this machine's; to another, with the
files of this machine its replay reads (:func:`packed`: its baseline, its local log, its
project's ``pyproject.toml``), written into a folder of the worker's in the same places
(:func:`unpacked`). Code is not shipped: a worker without the system's package makes the
DTC an error that says so (:func:`missing_system`). A task travels in one pickle
(:func:`shipped`), which Dask's scheduler passes on unopened; its body is
:func:`replayed`, whose outcomes come back in one pickle without their specs
(:func:`received` puts back the specs as given here), to be told as a local run tells
them (:func:`as_given`).
"""

from __future__ import annotations

import dataclasses
import importlib.util
import io
import pickle
import socket
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING, cast

from beatlog.baseline.file import expected_path
from beatlog.log.files import project_root
from beatlog.project.usercode import importable_near
from beatlog.suite.remote import Listed, fetch_ahead, wait_for
from beatlog.suite.runner import SpecOutcome, Verdict, run_spec
from beatlog.suite.spec import DtcSpec

if TYPE_CHECKING:
    from collections.abc import Sequence

    from beatlog.baseline.policy import SpecOptions

__all__ = [
    "Packed",
    "absolute",
    "as_given",
    "as_here",
    "missing_system",
    "packed",
    "received",
    "replayed",
    "shipped",
    "unpacked",
]

_OUTSIDE = "outside"


_Shipment = tuple[list["DtcSpec | Packed"], list[tuple[str, "Listed | None"]]]


def shipped(sent: list[DtcSpec | Packed], ahead: list[tuple[str, Listed | None]]) -> bytes:
    """A task for :func:`replayed`: its DTCs as sent, and the logs behind URLs it fetches
    ahead, in one pickle. Dask's scheduler passes bytes on as they are, where it would
    unpickle each spec and pickle it again for the worker."""
    return pickle.dumps((sent, ahead), pickle.HIGHEST_PROTOCOL)


def replayed(task: bytes, *, options: SpecOptions) -> bytes:
    """On a worker: the outcomes of the DTCs of a task (:func:`shipped`), in turn, while
    the logs it fetches ahead, which this thread likely replays later, are fetched into
    the machine's cache from the end of the first on (its own log's download goes
    first); pickled whole, each outcome's spec by its place alone (:func:`received`)."""
    sent, ahead = cast("_Shipment", pickle.loads(task))  # noqa: S301 - from the suite's client
    first = _replayed_one(sent[0], options)
    for url, listed in ahead:
        fetch_ahead(url, listed)
    outcomes = [first, *(_replayed_one(each, options) for each in sent[1:])]
    data = io.BytesIO()
    _Sending(data, outcomes).dump(outcomes)
    return data.getvalue()


def received(data: bytes, specs: Sequence[DtcSpec]) -> list[SpecOutcome]:
    """The outcomes :func:`replayed` sent for a task of ``specs``, each with its spec as
    given here: the client has its own, and a spec unpickled costs more than the rest
    of a passing DTC's outcome."""
    outcomes: list[SpecOutcome] = _Receiving(data, specs).load()
    return outcomes


class _Sending(pickle.Pickler):
    """Pickles a task's outcomes with the spec of each by its place among them."""

    def __init__(self, file: IO[bytes], outcomes: list[SpecOutcome]) -> None:
        super().__init__(file, pickle.HIGHEST_PROTOCOL)
        self._places = {id(outcome.spec): place for place, outcome in enumerate(outcomes)}

    def persistent_id(self, obj: object) -> int | None:
        return self._places.get(id(obj)) if isinstance(obj, DtcSpec) else None


class _Receiving(pickle.Unpickler):
    """Unpickles what :class:`_Sending` pickled, each spec the one of its place here."""

    def __init__(self, data: bytes, specs: Sequence[DtcSpec]) -> None:
        super().__init__(io.BytesIO(data))
        self._specs = specs

    def persistent_load(self, pid: int) -> DtcSpec:
        return self._specs[pid]


def _replayed_one(sent: DtcSpec | Packed, options: SpecOptions) -> SpecOutcome:
    """:func:`run_spec` of the DTC sent, with its files where it was packed."""
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


def absolute(spec: DtcSpec) -> DtcSpec:
    """The spec with absolute paths, for a worker whose working folder is not ours (a
    log behind a URL is named by its URL alone); a fleet's log behind a URL, which reads
    no file here, as it is."""
    if spec.log_url is not None and spec.spec_file is None:
        return spec
    log = spec.log if spec.log_url is not None else spec.log.absolute()
    return dataclasses.replace(spec, path=spec.path.absolute(), log=log)


def as_given(outcome: SpecOutcome, retries: int) -> SpecOutcome:
    """A worker's outcome, which :func:`received` gave its spec as given here, told as a
    local run tells it (relative paths stay relative): the same log, error, rerun command
    and baseline as a local run's, with the times its DTC was run again (``retries``).
    Copied only where one of them differs: a passing fleet log's outcome comes as is."""
    spec = outcome.spec
    result = outcome.result
    if result is not None:
        reproduce = outcome.reproduce
        if result.log != spec.log or result.reproduce != reproduce:
            result = dataclasses.replace(result, log=spec.log, reproduce=reproduce)
    error = outcome.error
    if error is not None:
        sent = absolute(spec)
        for there, given in ((sent.log, spec.log), (sent.path, spec.path)):
            error = error.replace(str(there), str(given))
    baseline = None if outcome.baseline is None else expected_path(spec.path)
    if (
        result is outcome.result
        and error == outcome.error
        and baseline == outcome.baseline
        and retries == outcome.retries
    ):
        return outcome
    return dataclasses.replace(
        outcome, result=result, error=error, baseline=baseline, retries=retries
    )
