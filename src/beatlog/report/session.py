"""One suite session for every shell: select the DTCs, run them, update their baselines,
then write the reports (JUnit, coverage JSON, HTML). What it did comes back as a
:class:`~beatlog.report.suite.SuiteReport`, which never prints; the pytest plugin ends
its run with :func:`conclude`, as ``beatlog test`` does."""

from __future__ import annotations

import contextlib
import dataclasses
import os
import time
from collections.abc import Callable, Mapping, Sequence
from contextlib import AbstractContextManager
from pathlib import Path
from typing import TYPE_CHECKING

from beatlog.baseline.policy import open_loop_share, stale_suite
from beatlog.errors import ClusterError, OptionError, SpecError
from beatlog.log.files import write_json
from beatlog.project.config import ProjectConfig, project_config
from beatlog.report.console import plain_text, render_outcome
from beatlog.report.suite import SuiteReport
from beatlog.suite.coverage import cache_path, recall, suite_coverage
from beatlog.suite.junit import write_junit
from beatlog.suite.maintenance import find_orphans, update_baselines, write_failed_variants
from beatlog.suite.parallel import run_suite
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.selection import (
    Selection,
    SuiteOptions,
    check_break_at,
    fleet_of,
    last_failed_path,
    remember_failed,
    select_suite,
)

if TYPE_CHECKING:
    from beatlog.analysis.recorded import RecordedChanges
    from beatlog.suite.cluster import DaskExecutor
    from beatlog.suite.spec import DtcSpec

__all__ = ["SuiteSession", "conclude", "prepare_report"]


class SuiteSession:
    """A suite run as ``beatlog test`` makes it: made, it selects the DTCs and refuses
    a report it could not write or break points the selection cannot take;
    :meth:`run` runs them, :meth:`finish` updates their baselines and writes reports.

    :raises EmptySelectionError: DTC specs are found, and none is selected.
    :raises OptionError: a report cannot be written, nothing is found, or the break
        points cannot be made.
    :raises SpecError: a spec, or the project's ``[tool.beatlog]``, cannot be read.
    :raises FleetError: a fleet run's logs cannot be listed.
    :raises SystemLoadError: a fleet run's system cannot be built.
    """

    def __init__(self, options: SuiteOptions) -> None:
        self.options = options
        fleet = fleet_of(options)
        for report in options.reports:
            prepare_report(report)
        self.selection: Selection = select_suite(options, fleet)
        root = self.selection.rootdir
        self.project = ProjectConfig() if root is None else project_config(root)
        """The project's configuration: its open-loop limits judge the suite."""
        check_break_at(options.break_at, self.specs, option="--break-at")
        if options.breaking and options.dask is not None:
            raise OptionError("break points stop in this process: leave out --dask")
        self._outcomes: dict[str, SpecOutcome] = {}
        self._wall_s = 0.0
        self._interrupted: KeyboardInterrupt | None = None
        self._lost: str | None = None

    @property
    def specs(self) -> list[DtcSpec]:
        """The DTCs the session runs."""
        return self.selection.specs

    @property
    def outcomes(self) -> list[SpecOutcome]:
        """The outcomes of the DTCs that ran, in spec order."""
        return [self._outcomes[spec.id] for spec in self.specs if spec.id in self._outcomes]

    def run(self, on_outcome: Callable[[SpecOutcome], object] | None = None) -> SuiteReport:
        """Run the DTCs (see :func:`~beatlog.suite.parallel.run_suite`), each outcome given
        to ``on_outcome`` as it comes; what ran, before anything is updated or written.
        A run stopped by Ctrl-C, by quitting the debugger at a break or by losing its
        cluster keeps what was complete: its report says what stopped it, and nothing is
        updated or written."""
        options = self.options

        def done(outcome: SpecOutcome) -> None:
            self._outcomes[outcome.spec.id] = outcome
            if on_outcome is not None:
                on_outcome(outcome)

        started = time.perf_counter()
        try:
            with _executor(options.dask) as executor:
                run_suite(
                    self.specs,
                    jobs=options.jobs or os.cpu_count() or 1,
                    fail_fast=options.fail_fast,
                    update=options.update,
                    audit=options.audit,
                    timelines=options.html is not None,
                    on_outcome=done,
                    break_at=options.break_at,
                    break_on_divergence=options.break_on_divergence,
                    coverage=options.coverage or options.coverage_json is not None,
                    executor=executor,
                )
        except KeyboardInterrupt as stop:
            self._interrupted = stop
        except ClusterError as lost:  # the outcomes that came before still count
            self._lost = str(lost)
        self._wall_s = time.perf_counter() - started
        return self._ran()

    def _ran(self) -> SuiteReport:
        return SuiteReport(
            outcomes=tuple(self.outcomes),
            selected=len(self.specs),
            wall_s=self._wall_s,
            audited=self.options.audit,
            interrupted=self._interrupted,
            error=self._lost,
        )

    def finish(self) -> SuiteReport:
        """Update the baselines and write the reports of a run that went to its end
        (the first pending file or report that cannot be written stops the writing: the
        report says why), and remember which DTCs failed, for ``--lf``; what the
        session did."""
        options, outcomes, report = self.options, self.outcomes, self._ran()
        if report.interrupted is not None or report.error is not None:
            return report
        try:
            updates = tuple(update_baselines(outcomes, options.update))
            variants = tuple(write_failed_variants(outcomes))
        except SpecError as exc:  # a full disk: the files written stay whole
            return dataclasses.replace(report, error=str(exc))
        report = dataclasses.replace(
            report,
            updates=updates,
            variant_specs=variants,
            stale=stale_suite(
                [
                    (o.spec.label, open_loop_share(o.result.cycles, o.open_loop[0]))
                    for o in outcomes
                    if o.verdict is Verdict.PASSED and o.result and o.open_loop
                ],
                max_share=self.project.max_open_loop_share,
                max_dtcs=self.project.max_open_loop_dtcs,
            ),
        )
        if options.junit_xml is not None:
            report = _written(
                report,
                options.junit_xml,
                lambda path: write_junit(
                    path, outcomes, describe=lambda outcome: plain_text(render_outcome(outcome))
                ),
            )
        report = conclude(
            report,
            [outcome.spec for outcome in outcomes if outcome.spec.variant is None],
            found=self.selection.found,
            root=self.selection.rootdir,
            orphans_in=options.paths if options.logs is None else (),
            coverage=options.coverage,
            coverage_json=options.coverage_json,
            recorded={o.spec.id: o.recorded for o in outcomes if o.recorded is not None},
        )
        if options.html is not None:
            from beatlog.report.html import write_html  # noqa: PLC0415 - charts, when asked for

            coverage = report.coverage
            report = _written(
                report, options.html, lambda path: write_html(outcomes, path, coverage=coverage)
            )
        root = self.selection.rootdir
        if report.error is None and root is not None:  # for the next run's --lf
            warning = remember_failed(outcomes, last_failed_path(root))
            report = dataclasses.replace(
                report, warnings=report.warnings + (() if warning is None else (warning,))
            )
        return report


def conclude(
    report: SuiteReport,
    ran: Sequence[DtcSpec],
    *,
    found: Sequence[DtcSpec],
    root: Path | None,
    orphans_in: Sequence[Path],
    coverage: bool = False,
    coverage_json: Path | None = None,
    recorded: Mapping[str, RecordedChanges] | None = None,
) -> SuiteReport:
    """The end of a suite session whose DTCs ``ran``: ``report`` with the orphaned
    baselines under ``orphans_in`` and, where asked for, the transition coverage, shown
    or written as JSON, marked with what earlier runs saw and remembered for the next in
    ``root``'s coverage memory (none without ``root``). ``found`` is every DTC of the
    suite, run or not; ``recorded`` the state changes the run gathered, by DTC id (the
    other logs are read). Nothing more is written once a report could not be."""
    report = dataclasses.replace(report, orphans=tuple(find_orphans(orphans_in)))
    if report.error is not None or not (coverage or coverage_json is not None):
        return report
    measured = suite_coverage(ran, recorded or {})
    warnings = report.warnings
    if root is not None:
        warning = recall(measured, cache_path(root), {spec.id: spec.name for spec in found})
        warnings += () if warning is None else (warning,)
    report = dataclasses.replace(
        report, coverage=measured, shows_coverage=coverage, warnings=warnings
    )
    if coverage_json is None:
        return report
    return _written(report, coverage_json, lambda path: write_json(path, measured.to_json()))


def prepare_report(report: Path) -> None:
    """Make a report's folder (as pytest's ``--junit-xml`` does) before any work, so
    that a report that cannot be written is found now, not after the whole suite.

    :raises OptionError: the report cannot be written there.
    """
    if report.is_dir():
        raise OptionError(f"{report}: is a directory")
    there = next(folder for folder in report.parents if folder.exists())
    if not there.is_dir():
        raise OptionError(f"{report}: {there} is not a directory")
    try:
        report.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OptionError(f"{report}: cannot write: {exc.strerror}") from None


def _written(report: SuiteReport, path: Path, write: Callable[[Path], None]) -> SuiteReport:
    """``report`` once ``write`` wrote ``path``, or with why it could not; nothing is
    written after a report that could not be."""
    if report.error is not None:
        return report
    try:
        write(path)
    except OSError as exc:
        return dataclasses.replace(report, error=f"{path}: cannot write: {exc.strerror}")
    return dataclasses.replace(report, written=(*report.written, path))


def _executor(address: str | None) -> AbstractContextManager[DaskExecutor | None]:
    """The Dask cluster at ``address``, connected to (or started) for the run; none
    without."""
    if address is None:
        return contextlib.nullcontext()
    from beatlog.suite.cluster import DaskExecutor  # noqa: PLC0415 - an optional extra

    return DaskExecutor(address)
