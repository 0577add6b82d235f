"""Which DTCs a suite session runs, from the options of ``beatlog test``
(:class:`SuiteOptions`): the specs found under its paths, or a fleet run's logs
(:func:`fleet_specs`); those that ``-k``, the tags and the behavior select; with
``--lf`` those that failed last time (:func:`rerun_failed`); the shard's share of them;
and the break points such a selection can take.

A fleet run replays every log that matches a local glob or an fsspec URL
(``s3://bucket/2024-*/*.beatlog``) against one system, each a DTC named after its file
and judged against its recording; a URL's pattern is expanded by listing alone. The
DTCs that failed are remembered by id in the project's cache folder, in
``lastfailed.json``, as pytest's ``--lf`` remembers them; a file that cannot be read or
trusted is ignored with a warning, never a crash.
"""

from __future__ import annotations

import glob
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Annotated, Any

import msgspec

from beatlog.baseline.policy import UpdateMode
from beatlog.errors import (
    EmptySelectionError,
    FleetError,
    OptionError,
    RemoteLogError,
    SystemLoadError,
)
from beatlog.log.limits import MAX_TEXT_LENGTH
from beatlog.project.usercode import load_perception, load_system
from beatlog.replay.debugger import beyond_the_log
from beatlog.suite.coverage import Text, cache_file, read_cached, select_exercising, write_cached
from beatlog.suite.discovery import discover_specs, distinguished, no_specs_found, select_specs
from beatlog.suite.parallel import Shard, shard
from beatlog.suite.remote import http_quoted, is_url, url_filesystem, url_name
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.spec import DtcSpec, find_rootdir
from beatlog.suite.variants import with_variants

__all__ = [
    "FLEET_PURPOSE",
    "MAX_REMEMBERED",
    "Selection",
    "SuiteOptions",
    "check_break_at",
    "fleet_of",
    "fleet_specs",
    "last_failed_path",
    "remember_failed",
    "rerun_failed",
    "select_suite",
]

FLEET_PURPOSE = "fleet log"
"""The purpose of every DTC of a fleet run."""
MAX_REMEMBERED = 100_000
"""Most failed DTCs remembered."""
_HERE = (Path(),)


class _LastFailed(msgspec.Struct, forbid_unknown_fields=True, tag_field="version", tag=1):
    dtcs: Annotated[list[Text], msgspec.Meta(max_length=MAX_REMEMBERED)]


@dataclass(frozen=True, kw_only=True)
class SuiteOptions:
    """A suite session's options (see :class:`beatlog.report.session.SuiteSession`),
    checked for how they go together when made.

    :raises OptionError: options that do not go together, named as ``beatlog test``
        names them: ``system`` or ``perception`` without ``logs`` (a spec names its
        own), ``logs`` without ``system``, or with ``paths``, an update or
        ``last_failed``.
    """

    paths: tuple[Path, ...] = _HERE
    """Specs (``*.dtc.toml``) or folders searched for them."""
    pattern: str | None = None
    """Only the DTCs matching this ``-k`` expression."""
    tags: tuple[str, ...] = ()
    """Only the DTCs with every one of these tags."""
    behavior: str | None = None
    """Only the DTCs whose recordings change this behavior's state."""
    shard: Shard | None = None
    """Only this shard's share of the DTCs selected."""
    logs: str | None = None
    """Replay every log matching this glob (or URL) against ``system``: no spec needed."""
    system: str | None = None
    """The system factory (``module:factory``) of a ``logs`` run."""
    perception: str | None = None
    """The perception step of a ``logs`` run."""
    jobs: int | None = None
    """Processes replaying at once; by default, the number of cores."""
    dask: str | None = None
    """The Dask cluster to run on (:class:`~beatlog.suite.cluster.DaskExecutor`)."""
    fail_fast: bool = False
    """Stop after the first DTC that fails or cannot run; those not started are not run."""
    last_failed: bool = False
    """Run only the DTCs selected that failed last time, or all when none did."""
    update: UpdateMode = UpdateMode.NONE
    audit: bool = False
    coverage: bool = False
    """Show the transition coverage (remembered in the coverage memory)."""
    coverage_json: Path | None = None
    junit_xml: Path | None = None
    html: Path | None = None
    break_at: int | None = None
    """Stop in the debugger just before the behaviors update in this cycle of the one
    DTC selected."""
    break_on_divergence: bool = False
    """Replay each failing DTC again and stop in the debugger at its first divergence."""
    variants: int | None = None
    """Variants 1..N of each DTC that declares variants (``[variants]``); None: as many
    as each declares (its ``count``)."""

    def __post_init__(self) -> None:
        if self.logs is None:
            if self.system is not None or self.perception is not None:
                raise OptionError("--system and --perception go with --logs: a spec names its own")
            return
        if self.system is None:
            raise OptionError("--logs needs --system MODULE:FACTORY to replay the logs against")
        if self.paths != _HERE:
            raise OptionError("give DTC specs or --logs, not both")
        if self.update is not UpdateMode.NONE:
            raise OptionError("--update writes the baselines of specs; --logs runs have none")
        if self.last_failed:
            raise OptionError("--lf reruns the specs that failed; --logs runs are not remembered")

    @property
    def reports(self) -> tuple[Path, ...]:
        """The report files to write."""
        reports = (self.junit_xml, self.html, self.coverage_json)
        return tuple(report for report in reports if report is not None)

    @property
    def breaking(self) -> bool:
        """Whether the run stops in the debugger."""
        return self.break_at is not None or self.break_on_divergence


@dataclass(frozen=True)
class Selection:
    """The DTCs of a suite session."""

    found: list[DtcSpec]
    """Every DTC found, selected or not."""
    specs: list[DtcSpec]
    """Those the session runs, in path order; those that share a name are named by
    their ids (:func:`~beatlog.suite.discovery.distinguished`)."""
    rootdir: Path | None
    """The rootdir of the specs, as pytest would take it; None for a fleet run's logs."""
    note: str | None = None
    """What ``--lf`` or ``--variants`` did to the selection, for the reader."""


def fleet_of(options: SuiteOptions) -> list[DtcSpec] | None:
    """The DTCs of a fleet run's logs (:func:`fleet_specs`); None without ``logs``. Every
    log of a fleet names the same system (and perception step): it is built once here,
    so that one that cannot be built is one error of the run.

    :raises SystemLoadError: it cannot be built; the message starts with its option.
    """
    if options.logs is None:
        return None
    assert options.system is not None, "SuiteOptions checks it"
    fleet = fleet_specs(options.logs, system=options.system, perception=options.perception)
    references = (
        ("--system", options.system, load_system),
        ("--perception", options.perception, load_perception),
    )
    for option, reference, load in references:  # none from beside the logs (never trusted)
        if reference is None:
            continue
        try:
            load(reference)
        except SystemLoadError as exc:
            raise SystemLoadError(f"{option} {exc}", user_traceback=exc.user_traceback) from None
    return fleet


def select_suite(options: SuiteOptions, fleet: list[DtcSpec] | None = None) -> Selection:
    """The specs found under the options' paths (or the ``fleet`` given), and those the
    session runs: selected by ``-k``, the tags, the behavior, ``--lf`` and the shard,
    each followed by its variants unless the run stops in the debugger.

    :raises EmptySelectionError: specs are found, and none is selected.
    :raises OptionError: nothing is found.
    :raises SpecError: a spec cannot be read.
    """
    found = discover_specs(options.paths) if fleet is None else fleet
    rootdir = find_rootdir(options.paths) if fleet is None else None
    specs = select_specs(found, pattern=options.pattern, tags=options.tags, rootdir=rootdir)
    if specs and options.behavior is not None:
        specs = select_exercising(specs, options.behavior)
    if not specs:
        where = " ".join(map(str, options.paths)) if fleet is None else options.logs
        if found:
            raise EmptySelectionError(
                f"none of the {len(found)} DTC specs in {where} match -k/--tag"
            )
        raise OptionError(no_specs_found(options.paths))
    note = None
    if options.last_failed and rootdir is not None:
        specs, note = rerun_failed(specs, last_failed_path(rootdir))
    if options.shard is not None:
        specs = shard(specs, options.shard.index, options.shard.count)
    if not options.breaking:
        specs = with_variants(specs, options.variants)
    if options.variants and not any(spec.variant for spec in specs):
        unvaried = (
            "--variants: no DTC selected declares variants "
            "([variants] in its spec, or [tool.beatlog.variants])"
        )
        note = unvaried if note is None else f"{note}\n{unvaried}"
    return Selection(found, distinguished(specs), rootdir, note)


def check_break_at(break_at: int | None, specs: Sequence[DtcSpec], *, option: str) -> None:
    """A break at a cycle stops in one DTC: refuse a selection of more, or one whose
    local log ends before the break. ``option`` is the break's option, as named.

    :raises OptionError: the break cannot be made.
    """
    if break_at is None:
        return
    if len(specs) > 1:
        raise OptionError(
            f"{option} stops in one DTC, and {len(specs)} are selected: "
            "name its spec or select it with -k"
        )
    if specs and specs[0].log_url is None and (problem := beyond_the_log(break_at, specs[0].log)):
        raise OptionError(f"{option} {break_at}: {problem}")


def fleet_specs(pattern: str, *, system: str, perception: str | None = None) -> list[DtcSpec]:
    """The DTCs of the logs that match ``pattern``, in the order of their paths, each
    replayed against ``system`` (and ``perception``); nothing behind a URL is read.

    :raises FleetError: nothing matches, a URL needs fsspec, or its listing fails.
    """
    if ":" not in system:
        raise FleetError(f"--system: expected module:factory, got {system!r}")
    if perception is not None and ":" not in perception:
        raise FleetError(f"--perception: expected module:factory, got {perception!r}")
    found: list[tuple[str, str | None, dict[str, Any]]] = []  # path, URL, listing
    if is_url(pattern):
        try:
            filesystem, root = url_filesystem(http_quoted(pattern))
        except RemoteLogError as exc:
            raise FleetError(f"--logs {exc}") from None
        try:
            matches: dict[str, dict[str, Any]] = filesystem.glob(root, detail=True)
        except (ImportError, OSError, ValueError) as exc:  # ImportError: a backend's package
            raise FleetError(f"--logs {pattern}: cannot list: {exc}") from None
        found = [
            (path, filesystem.unstrip_protocol(path), info)
            for path, info in sorted(matches.items())
            if info.get("type") != "directory"
        ]
    else:
        paths = sorted(glob.glob(os.path.expanduser(pattern), recursive=True))
        found = [(path, None, {}) for path in paths if not os.path.isdir(path)]
    if not found:
        raise FleetError(f"--logs {pattern}: no log matches")
    specs = []
    for path, url, info in found:
        size, etag = info.get("size"), info.get("ETag", info.get("etag"))
        name = path if url is None else url_name(url)
        specs.append(
            DtcSpec(
                path=Path(path),
                name=PurePosixPath(name).stem,
                purpose=FLEET_PURPOSE,
                procedure=(),
                log=Path(name),
                system=system,
                perception=perception,
                source=url or path,
                log_url=url,
                log_size=size if isinstance(size, int) and size >= 0 else None,
                log_etag=etag if isinstance(etag, str) and etag else None,
            )
        )
    return specs


def last_failed_path(root: Path) -> Path:
    """Where the suite at ``root`` (a spec or a folder of specs) remembers its failures."""
    return cache_file(root, "lastfailed.json")


def rerun_failed(specs: Sequence[DtcSpec], path: Path) -> tuple[list[DtcSpec], str]:
    """Of ``specs``, those that failed last time (as remembered at ``path``), and a line
    saying so; all of them when none did, the line saying that too."""
    failed, warning = _failed(path)
    ids = set(failed)
    chosen = [spec for spec in specs if spec.id in ids]
    if chosen:
        count = f"{len(chosen)} DTC{'s' if len(chosen) > 1 else ''}"
        said = f"--lf: rerunning the {count} that failed last time"
    else:
        said = f"--lf: no DTC selected failed last time; running all {len(specs)}"
    return (chosen or list(specs)), said if warning is None else f"{said} ({warning})"


def remember_failed(outcomes: Sequence[SpecOutcome], path: Path) -> str | None:
    """Remember at ``path`` which of ``outcomes`` failed (a verdict other than passed,
    or an audit that found something), forgetting those that passed; the file is written
    only when that changes it. A warning when it cannot be read or written."""
    before, warning = _failed(path)
    ran = {outcome.spec.id for outcome in outcomes}
    failed = {
        outcome.spec.id
        for outcome in outcomes
        if outcome.verdict is not Verdict.PASSED or outcome.audit_findings
    }
    after = [dtc for dtc in before if dtc not in ran or dtc in failed]
    after += sorted(failed - set(after))
    after = [dtc for dtc in after if len(dtc) <= MAX_TEXT_LENGTH][:MAX_REMEMBERED]
    if after == before and warning is None:
        return None
    try:
        write_cached(path, _LastFailed(after))
    except OSError as exc:
        return f"{path}: cannot write: {exc.strerror or exc}; the failures are not remembered"
    return warning


def _failed(path: Path) -> tuple[list[str], str | None]:
    """The DTCs remembered at ``path`` as failed, and a warning where it is unusable."""
    memory, warning = read_cached(path, _LastFailed, "a beatlog memory of failed DTCs")
    return ([] if memory is None else memory.dtcs), warning
