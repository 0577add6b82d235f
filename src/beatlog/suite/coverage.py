"""A suite's transition coverage, from its specs: what each DTC's recording exercises."""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

from beatlog.analysis.coverage import SuiteCoverage, cover_changes
from beatlog.analysis.recorded import RecordedChanges, read_changes
from beatlog.errors import BeatlogError, LogError, OptionError, RemoteLogError
from beatlog.model.behavior import System
from beatlog.project.config import vouched_system
from beatlog.project.usercode import load_system
from beatlog.replaying.expectation import TracedChange
from beatlog.suite.spec import DtcSpec

__all__ = ["select_exercising", "suite_coverage"]


def suite_coverage(
    specs: Sequence[DtcSpec], recorded: Mapping[str, RecordedChanges] | None = None
) -> SuiteCoverage:
    """The coverage of ``specs``: the state changes their logs recorded (from
    ``recorded``, by spec id, where their run gathered them; else read from the logs),
    with each behavior's first and declared states from a fresh system of each spec,
    system by system (a spec's ``system``, else the one its log records). A log that
    cannot be read (damaged, not a log, behind a URL that cannot be copied) counts
    nothing: its DTC's verdict says what is wrong, and the other logs still count. DTCs
    are known by their ids, and named as the specs' labels say."""
    coverage = cover_changes(_dtcs(specs, unreadable=set(), recorded=recorded or {}))
    coverage.labels = {spec.id: spec.label for spec in specs}
    return coverage


def _dtcs(
    specs: Sequence[DtcSpec],
    *,
    unreadable: set[Path],
    systems: bool = True,
    recorded: Mapping[str, RecordedChanges],
) -> Iterator[tuple[str, str, list[TracedChange], int, System | None]]:
    """Each readable spec's id and system, the state changes its log recorded and its
    cycles (from ``recorded``, else read from the log, one behind a URL copied for as
    long as it is read), and a fresh system when ``systems`` (None where none can be
    built); the paths of the specs whose log cannot be read go to ``unreadable``."""
    for spec in specs:
        changes = recorded.get(spec.id)
        if changes is None:
            try:
                changes = _read(spec)
            except (LogError, RemoteLogError):
                unreadable.add(spec.path)
                continue
        system: System | None = None
        if systems:
            try:
                system = load_system(
                    spec.system
                    or vouched_system(spec.log, changes.reference, project=spec.path.parent)
                )
            except BeatlogError:  # the verdict reports it; coverage counts the log
                system = None
        yield spec.id, spec.system or changes.system, changes.changes, changes.cycles, system


def _read(spec: DtcSpec) -> RecordedChanges:
    """The state changes ``spec``'s log recorded, read from it."""
    with spec.readable_log() as log:
        return read_changes(log)


def select_exercising(specs: Sequence[DtcSpec], behavior: str) -> list[DtcSpec]:
    """The specs whose recordings change ``behavior``'s state (read from the logs alone:
    no system is built), and those whose log cannot be read, so that their verdicts say
    what is wrong with it.

    :raises beatlog.errors.OptionError: none does and every log could be read; the
        message names the behaviors whose states they change.
    """
    unreadable: set[Path] = set()
    coverage = cover_changes(_dtcs(specs, unreadable=unreadable, systems=False, recorded={}))
    names = set(coverage.exercising(behavior))
    if not names and not unreadable:
        changed = dict.fromkeys(cover.behavior for cover in coverage.behaviors if cover.transitions)
        raise OptionError(
            f"no DTC changes the state of behavior {behavior!r}; they change "
            + (", ".join(changed) or "none")
        )
    return [spec for spec in specs if spec.id in names or spec.path in unreadable]
