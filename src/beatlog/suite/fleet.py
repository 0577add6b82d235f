"""Fleet runs: every session log that matches a pattern replayed against one system, with
no spec per log (``beatlog test --logs 'logs/**/*.beatlog' --system MODULE:FACTORY``).

Each log becomes a DTC of its own, named after its file (and identified by its path or
URL: two logs may share a file name) and judged against its recording: a fleet log has
no approved baseline. The pattern is a local glob, or any
fsspec URL (``s3://bucket/2024-*/*.beatlog``) where fsspec is installed
(``pip install "beatlog[fleet]"``). A URL's pattern is expanded by listing alone,
one call that gives each log's size (what orders the work) and ETag too: each log
behind it is copied only by the process that replays it, locally or on a Dask worker,
with that one download its only request, and none where the machine's cache holds
the object of that ETag (see :mod:`beatlog.suite.remote`).
"""

from __future__ import annotations

import glob
import os
from pathlib import Path, PurePosixPath
from typing import Any

from beatlog.errors import FleetError, RemoteLogError, SystemLoadError
from beatlog.project.usercode import importable_near, load_perception, load_system
from beatlog.suite.remote import http_quoted, is_url, url_filesystem, url_name
from beatlog.suite.spec import DtcSpec

__all__ = ["FLEET_PURPOSE", "check_references", "fleet_specs"]

FLEET_PURPOSE = "fleet log"
"""The purpose of every DTC of a fleet run."""


def fleet_specs(pattern: str, *, system: str, perception: str | None = None) -> list[DtcSpec]:
    """The DTCs of the logs that match ``pattern``, in the order of their paths, each
    replayed against ``system`` (and ``perception``, when given). Nothing behind a URL
    is read: the listing names the logs.

    :raises FleetError: nothing matches, a URL needs fsspec, or its listing fails.
    """
    if ":" not in system:
        raise FleetError(f"--system: expected module:factory, got {system!r}")
    if perception is not None and ":" not in perception:
        raise FleetError(f"--perception: expected module:factory, got {perception!r}")

    def spec(
        path: Path,
        source: str,
        log_url: str | None = None,
        size: int | None = None,
        etag: str | None = None,
    ) -> DtcSpec:
        return DtcSpec(
            path=path,
            name=PurePosixPath(path if log_url is None else url_name(log_url)).stem,
            purpose=FLEET_PURPOSE,
            procedure=(),
            log=path if log_url is None else Path(url_name(log_url)),
            system=system,
            perception=perception,
            source=source,
            log_url=log_url,
            log_size=size,
            log_etag=etag,
        )

    if not is_url(pattern):
        return [spec(Path(path), path) for path in _local_logs(pattern)]
    filesystem, found = _remote_logs(pattern)
    return [
        spec(Path(path), url, url, size, etag)
        for path, size, etag in found
        for url in [filesystem.unstrip_protocol(path)]
    ]


def check_references(spec: DtcSpec) -> None:
    """Build the system (and perception step) of a fleet's DTC once, as its replay
    builds them: every log of a fleet names the same ones, so one that cannot be built
    is one error of the run, not one per log.

    :raises SystemLoadError: the reference cannot be imported or does not build one; the
        message starts with the option that gave it.
    """
    references = (
        ("--system", spec.system, load_system),
        ("--perception", spec.perception, load_perception),
    )
    with importable_near(spec.spec_file):
        for option, reference, load in references:
            if reference is None:
                continue
            try:
                load(reference)
            except SystemLoadError as exc:
                raise SystemLoadError(
                    f"{option} {exc}", user_traceback=exc.user_traceback
                ) from None


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


def _remote_logs(pattern: str) -> tuple[Any, list[tuple[str, int | None, str | None]]]:
    """The filesystem behind a URL and the files its glob matches, sorted, each with its
    size in bytes and its ETag as the same listing gives them (None where it does not
    say): planning the work then asks the storage nothing per log, nor, with both,
    copying a log anything but its download."""
    try:
        filesystem, root = url_filesystem(http_quoted(pattern))
    except RemoteLogError as exc:
        raise FleetError(f"--logs {exc}") from None
    try:
        matches: dict[str, dict[str, Any]] = filesystem.glob(root, detail=True)
    except (ImportError, OSError, ValueError) as exc:  # ImportError: a backend's package
        raise FleetError(f"--logs {pattern}: cannot list: {exc}") from None
    found = sorted(
        (path, _listed_size(info), _listed_etag(info))
        for path, info in matches.items()
        if info.get("type") != "directory"
    )
    if not found:
        raise FleetError(f"--logs {pattern}: no log matches")
    return filesystem, found


def _listed_size(info: dict[str, Any]) -> int | None:
    """A listed file's size in bytes, None where the listing does not give one."""
    size = info.get("size")
    return size if isinstance(size, int) and size >= 0 else None


def _listed_etag(info: dict[str, Any]) -> str | None:
    """A listed file's ETag, None where the listing does not give one."""
    etag = info.get("ETag", info.get("etag"))
    return etag if isinstance(etag, str) and etag else None
