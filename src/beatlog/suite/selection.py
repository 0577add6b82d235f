"""Which DTCs a suite session runs: the specs found under its paths (or a fleet run's
logs), those that ``-k``, the tags and the behavior select, the shard's share of them,
and the break points such a selection can take."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from beatlog.errors import EmptySelectionError, OptionError
from beatlog.replaying.debugger import beyond_the_log
from beatlog.suite.coverage import select_exercising
from beatlog.suite.discovery import discover_specs, distinguished, select_specs
from beatlog.suite.fleet import check_references, fleet_specs
from beatlog.suite.last_failed import last_failed_path, rerun_failed
from beatlog.suite.options import SuiteOptions
from beatlog.suite.sharding import shard
from beatlog.suite.spec import DtcSpec, find_rootdir
from beatlog.suite.variants import with_variants

__all__ = ["Selection", "check_break_at", "fleet_of", "select_suite"]


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
    """The DTCs of a fleet run's logs, their system (and perception step) built once to
    check it; None without ``logs``.

    :raises FleetError: no log matches, or they cannot be listed.
    :raises SystemLoadError: the system or the perception step cannot be built.
    """
    if options.logs is None:
        return None
    assert options.system is not None, "SuiteOptions checks it"
    fleet = fleet_specs(options.logs, system=options.system, perception=options.perception)
    check_references(fleet[0])
    return fleet


def select_suite(options: SuiteOptions, fleet: list[DtcSpec] | None = None) -> Selection:
    """The specs found under the options' paths (or the ``fleet`` given), and those the
    session runs: selected by ``-k`` and the tags, then by the behavior they exercise,
    then with ``--lf`` those that failed last time, and of those the shard's share;
    each followed by its variants (:func:`~beatlog.suite.variants.with_variants`),
    unless the run stops in the debugger.

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
        raise OptionError(f"no DTC specs to run in {where} (looked for *.dtc.toml)")
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
    """A break at a cycle stops in one DTC: refuse a selection of more, or one whose log
    ends before the break (as its end record counts its cycles; a log behind a URL is
    not read for it). ``option`` is the break's option, as the error names it.

    :raises OptionError: the break cannot be made.
    """
    if break_at is None:
        return
    if len(specs) > 1:
        raise OptionError(
            f"{option} stops in one DTC, and {len(specs)} are selected: "
            "name its spec or select it with -k"
        )
    problem = None
    if specs and specs[0].log_url is None:
        problem = beyond_the_log(break_at, specs[0].log)
    if problem is not None:
        raise OptionError(f"{option} {break_at}: {problem}")
