"""What a DTC takes to a cluster's worker that does not share this machine's files: the
spec with its paths relative to its project's root, and the files its replay reads (its
baseline, its log where local, its project's ``pyproject.toml``), unpacked in a folder
of the worker's own (:class:`~beatlog.suite.cluster.DaskExecutor` ships them)."""

from __future__ import annotations

import dataclasses
import importlib.util
from dataclasses import dataclass
from pathlib import Path

from beatlog.baseline.file import expected_path
from beatlog.log.files import project_root
from beatlog.suite.spec import DtcSpec

__all__ = ["Packed", "as_here", "missing_system", "packed", "unpacked"]

_OUTSIDE = "outside"


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
