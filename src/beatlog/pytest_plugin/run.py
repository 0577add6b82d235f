"""What one pytest run asks of its DTCs and what they did: the plugin object that
gathers their verdicts for the terminal summary, and keeps their audit interpreters."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from beatlog.errors import BeatlogError, OptionError
from beatlog.pytest_plugin.items import OPEN_LOOP, SPEC, UPDATE, VERDICT, DtcItem
from beatlog.suite.discovery import discover_specs, distinguished
from beatlog.suite.policy import SpecOptions, UpdateMode
from beatlog.suite.spec import DtcSpec, load_spec

if TYPE_CHECKING:
    from beatlog.analysis.recorded import RecordedChanges
    from beatlog.report.suite import SuiteReport
    from beatlog.suite.runner import Verdict

__all__ = ["BeatlogRun"]


@dataclass(eq=False)  # registered as a plugin: pluggy keeps plugins in sets
class BeatlogRun:
    """What this pytest run asks of its DTCs, and what they did, for the terminal summary."""

    update: UpdateMode
    audit: bool
    root: Path
    """pytest's rootdir: the coverage memory goes to its project root."""
    coverage: bool = False
    coverage_json: Path | None = None
    break_at: int | None = None
    break_on_divergence: bool = False
    worker: bool = False
    """Whether this is an xdist worker's run: its DTCs' verdicts go to the controller's."""
    verdicts: list[Verdict] = field(default_factory=list)
    specs: set[Path] = field(default_factory=set)
    """The specs that ran: their folders are where orphaned baselines are looked for."""
    lines: list[str] = field(default_factory=list)
    """What updating the baselines did."""
    open_loop: int = 0
    """The DTCs judged against baselines whose behaviors left the recording."""
    recorded: dict[Path, RecordedChanges] = field(default_factory=dict)
    """By spec, the state changes its log recorded, as its verdict's replay read them
    for the coverage (here; an xdist worker's DTCs' logs are read again for it)."""

    @property
    def options(self) -> SpecOptions:
        """What each DTC is run with."""
        return SpecOptions(
            update=self.update,
            audit=self.audit,
            break_at=self.break_at,
            break_on_divergence=self.break_on_divergence,
            coverage=(self.coverage or self.coverage_json is not None) and not self.worker,
        )

    def pytest_collection_finish(self, session: pytest.Session) -> None:
        """A break at a cycle stops in one DTC: refuse a run that selects more, or one
        whose log ends before the break (as ``beatlog test`` does). The DTCs selected
        that share a name are named by their ids in what beatlog reports."""
        selected = [item for item in session.items if isinstance(item, DtcItem)]
        for item, spec in zip(selected, distinguished(item.spec for item in selected), strict=True):
            item.spec = spec
        if self.break_at is None:
            return
        from beatlog.suite.selection import check_break_at  # noqa: PLC0415 - see the imports

        try:
            check_break_at(
                self.break_at, [item.spec for item in selected], option="--beatlog-break-at"
            )
        except OptionError as exc:
            raise pytest.UsageError(str(exc)) from None

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        """Gather a DTC's verdict and update lines from its report (a worker's, under xdist):
        the call's, or the setup's where the DTC could not run."""
        if report.when != "call" and not (report.when == "setup" and report.failed):
            return
        from beatlog.suite.runner import Verdict  # noqa: PLC0415 - see the imports

        for name, value in report.user_properties:
            if name == VERDICT:
                self.verdicts.append(Verdict(str(value)))
            elif name == SPEC:
                self.specs.add(Path(str(value)))
            elif name == UPDATE:
                self.lines.append(str(value))
            elif name == OPEN_LOOP:
                self.open_loop += 1

    def pytest_terminal_summary(self, terminalreporter: pytest.TerminalReporter) -> None:
        """The pending baselines written, the orphans, the coverage and the DTCs' verdicts."""
        if not self.verdicts:
            return
        from beatlog.report.counts import plural, verdict_counts  # noqa: PLC0415 - see the imports
        from beatlog.report.suite import plain_lines  # noqa: PLC0415

        report, problem = self._report()
        lines = [*self.lines, *plain_lines(report.orphan_lines())]
        if problem is not None:
            lines.append(f"beatlog: {problem}")
        lines.extend(f"beatlog: warning: {warning}" for warning in report.warnings)
        lines.extend(plain_lines(report.coverage_lines()))
        if report.error is not None:
            lines.append(f"beatlog: warning: {report.error}")
        terminalreporter.section("beatlog")
        for line in lines:
            terminalreporter.write_line(line)
        counts = verdict_counts(self.verdicts, open_loop=self.open_loop)
        terminalreporter.write_line(f"{plural(len(self.verdicts), 'DTC')}: {counts}")

    def _report(self) -> tuple[SuiteReport, str | None]:
        """The end of the session, as ``beatlog test`` ends one (see
        :func:`beatlog.suite_session.conclude`), for the specs that ran; with why there
        is no coverage where it was asked for and the specs could not be read again."""
        from beatlog.report.suite import SuiteReport  # noqa: PLC0415 - see the imports
        from beatlog.suite_session import conclude  # noqa: PLC0415

        folders = sorted({spec.parent for spec in self.specs})
        measured = self.coverage or self.coverage_json is not None
        ran: list[DtcSpec] = []
        found: list[DtcSpec] = []
        problem = None
        if measured:
            try:
                ran = distinguished(
                    load_spec(spec, rootdir=self.root) for spec in sorted(self.specs)
                )
                found = discover_specs(folders, rootdir=self.root)  # those deselected too
            except BeatlogError as exc:  # a log no DTC could read: its error is reported
                measured, problem = False, f"no transition coverage: {exc}"
        report = conclude(
            SuiteReport(),
            ran,
            found=found,
            root=self.root,
            orphans_in=folders,
            coverage=self.coverage and measured,
            coverage_json=self.coverage_json if measured else None,
            recorded={
                spec.id: self.recorded[spec.path] for spec in ran if spec.path in self.recorded
            },
        )
        return report, problem
