"""Fleet runs: every session log that matches a pattern replayed against one system, with
no spec per log (``beatlog test --logs 'logs/**/*.beatlog' --system MODULE:FACTORY``).

Each log becomes a DTC of its own, named after its file and judged against its
recording: a fleet log has no approved baseline. The pattern is a local glob, or any
fsspec URL (``s3://bucket/2024-*/*.beatlog``) where fsspec is installed
(``pip install "beatlog[fleet]"``). The reader needs a regular, seekable file, so each
log behind a URL is first copied into a temporary folder, up to ``max_log_bytes``; the
copies are removed when the run ends. On a Dask cluster (:mod:`beatlog.suite.cluster`)
each worker copies the log it replays itself, with :func:`fetched_log`.
"""

from __future__ import annotations

import contextlib
import glob
import os
import re
import tempfile
from collections.abc import Iterator
from pathlib import Path, PurePosixPath
from typing import Any

from beatlog.errors import FleetError
from beatlog.suite.spec import DtcSpec

__all__ = ["FLEET_PURPOSE", "MAX_LOG_BYTES", "fetched_log", "fleet_specs", "is_url"]

FLEET_PURPOSE = "fleet log"
"""The purpose of every DTC of a fleet run."""
MAX_LOG_BYTES = 4 << 30
"""The largest log copied from a URL: far more than hours of recording."""
_URL = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*://")
_BLOCK = 1 << 20


@contextlib.contextmanager
def fleet_specs(
    pattern: str,
    *,
    system: str,
    perception: str | None = None,
    max_log_bytes: int = MAX_LOG_BYTES,
) -> Iterator[list[DtcSpec]]:
    """The DTCs of the logs that match ``pattern``, in the order of their paths, each
    replayed against ``system`` (and ``perception``, when given).

    A context manager: the copies of logs behind a URL live until it exits.

    :raises FleetError: nothing matches, a URL needs fsspec, or a log behind a URL
        cannot be copied or is larger than ``max_log_bytes``.
    """
    if ":" not in system:
        raise FleetError(f"--system: expected module:factory, got {system!r}")
    if perception is not None and ":" not in perception:
        raise FleetError(f"--perception: expected module:factory, got {perception!r}")

    def spec(log: Path, source: str, name: str) -> DtcSpec:
        return DtcSpec(
            path=log,
            name=PurePosixPath(name).stem,
            purpose=FLEET_PURPOSE,
            procedure=(),
            log=log,
            system=system,
            perception=perception,
            source=source,
        )

    if not is_url(pattern):
        found = _local_logs(pattern)
        yield [spec(Path(path), path, path) for path in found]
        return
    filesystem, found = _remote_logs(pattern)
    with tempfile.TemporaryDirectory(prefix="beatlog-fleet-") as folder:
        specs = []
        for number, path in enumerate(found):
            url = filesystem.unstrip_protocol(path)
            copy = Path(folder, str(number), PurePosixPath(path).name)
            copy.parent.mkdir()
            _copy(filesystem, path, copy, url, max_log_bytes)
            specs.append(spec(copy, url, path))
        yield specs


def is_url(text: str) -> bool:
    """Whether a log's pattern or source is a URL (``s3://...``) rather than a local path."""
    return _URL.match(text) is not None


@contextlib.contextmanager
def fetched_log(url: str, max_log_bytes: int = MAX_LOG_BYTES) -> Iterator[Path]:
    """A copy of the log behind ``url`` in a temporary folder of this machine, removed on
    exit.

    :raises FleetError: the URL needs fsspec, or the log cannot be copied or is larger
        than ``max_log_bytes``.
    """
    filesystem, path = _filesystem(url, "cannot copy")
    with tempfile.TemporaryDirectory(prefix="beatlog-fleet-") as folder:
        copy = Path(folder, PurePosixPath(path).name)
        _copy(filesystem, path, copy, url, max_log_bytes)
        yield copy


def _local_logs(pattern: str) -> list[str]:
    """The files that a local glob (``**`` for any folders) matches, sorted."""
    found = sorted(
        path
        for path in glob.glob(os.path.expanduser(pattern), recursive=True)
        if not os.path.isdir(path)
    )
    if not found:
        raise FleetError(f"--logs {pattern}: no log matches")
    return found


def _filesystem(url: str, problem: str) -> tuple[Any, str]:
    """The fsspec filesystem behind a URL, and the URL's path on it; ``problem`` says
    what cannot be done without them."""
    try:
        from fsspec.core import url_to_fs  # noqa: PLC0415 - an optional dependency
    except ModuleNotFoundError:
        raise FleetError(
            f'--logs {url}: a URL needs fsspec (pip install "beatlog[fleet]")'
        ) from None
    try:
        filesystem, path = url_to_fs(url)
    except (ImportError, ValueError) as exc:  # ImportError: a backend's package
        raise FleetError(f"--logs {url}: {problem}: {exc}") from None
    return filesystem, path


def _remote_logs(pattern: str) -> tuple[Any, list[str]]:
    """The filesystem behind a URL and the files its glob matches, sorted."""
    filesystem, root = _filesystem(pattern, "cannot list")
    try:
        matches: dict[str, dict[str, Any]] = filesystem.glob(root, detail=True)
    except (ImportError, OSError, ValueError) as exc:  # ImportError: a backend's package
        raise FleetError(f"--logs {pattern}: cannot list: {exc}") from None
    found = sorted(path for path, info in matches.items() if info.get("type") != "directory")
    if not found:
        raise FleetError(f"--logs {pattern}: no log matches")
    return filesystem, found


def _copy(filesystem: Any, path: str, copy: Path, url: str, max_bytes: int) -> None:
    """Copy one remote log, refusing it once it passes ``max_bytes``."""
    too_big = f"{url}: larger than the {max_bytes} bytes a fleet log may have"
    try:
        size = filesystem.size(path)
        if size is not None and size > max_bytes:
            raise FleetError(too_big)
        copied = 0
        with filesystem.open(path, "rb") as source, copy.open("wb") as target:
            while block := source.read(_BLOCK):
                copied += len(block)
                if copied > max_bytes:  # a size the listing got wrong
                    raise FleetError(too_big)
                target.write(block)
    except OSError as exc:
        raise FleetError(f"{url}: cannot copy: {exc}") from None
