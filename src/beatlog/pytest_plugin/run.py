"""One pytest run of DTC specs: a ``*.dtc.toml`` file is one item, judged in its setup,
and the plugin object of the run gathers what the DTCs asked and did for the terminal
summary, and keeps their audit interpreters."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from beatlog.baseline.policy import (
    SpecOptions,
    StaleSuite,
    open_loop_share,
    stale_suite,
)
from beatlog.errors import BeatlogError, OptionError, SpecError
from beatlog.suite.discovery import discover_specs, distinguished
from beatlog.suite.spec import DtcSpec, load_spec
from beatlog.suite.variants import with_variants

if TYPE_CHECKING:
    from beatlog.analysis.recorded import RecordedChanges
    from beatlog.replay.verdict import ReplayResult
    from beatlog.report.suite import SuiteReport
    from beatlog.suite.runner import SpecOutcome, Verdict

__all__ = ["RUN", "BeatlogRun", "DtcFile", "DtcItem", "failure_text", "quitting_as_pytest"]

VERDICT, SPEC, UPDATE = "beatlog_verdict", "beatlog_spec", "beatlog_update"
OPEN_LOOP = "beatlog_open_loop"
"""Names of the user properties a DTC's report carries to the summary (across xdist)."""

RUN: pytest.StashKey[BeatlogRun] = pytest.StashKey()
"""Where a pytest run keeps its :class:`BeatlogRun`."""


class DtcFailedError(AssertionError):
    """A DTC that diverged; carries the text pytest shows."""


class DtcFile(pytest.File):
    """A ``*.dtc.toml`` spec file: one test item, and one per variant it declares."""

    def collect(self) -> Iterator[pytest.Item]:
        try:
            spec = load_spec(self.path, rootdir=self.config.rootpath)
        except SpecError as exc:
            raise self.CollectError(str(exc)) from None
        for dtc in with_variants([spec], self.config.stash[RUN].variants):
            yield DtcItem.from_parent(self, name=dtc.name, spec=dtc)


class DtcItem(pytest.Item):
    """One deterministic test case: replay the spec's log against its system."""

    def __init__(self, *, spec: DtcSpec, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.spec = spec
        self.outcome: SpecOutcome | None = None
        self.add_marker("dtc")
        self.extra_keyword_matches.update(spec.tags)

    def setup(self) -> None:
        """Judge the DTC: one that cannot run (its log or system is bad input) is an error
        of this phase, so pytest reports it as an ERROR, as ``beatlog test`` does."""
        from beatlog.report.baselines import render_updates  # noqa: PLC0415 - see the imports
        from beatlog.report.suite import variant_lines  # noqa: PLC0415
        from beatlog.suite.maintenance import (  # noqa: PLC0415
            update_baselines,
            write_failed_variants,
        )
        from beatlog.suite.runner import Verdict, run_spec  # noqa: PLC0415

        run = self.config.stash[RUN]
        with quitting_as_pytest():
            outcome = self.outcome = run_spec(self.spec, run.options)
        if outcome.recorded is not None:
            run.recorded[self.spec.path] = outcome.recorded
        self.user_properties.append((VERDICT, outcome.verdict.value))
        self.user_properties.append((SPEC, str(self.spec.path)))
        if outcome.open_loop is not None and outcome.result is not None:
            share = open_loop_share(outcome.result.cycles, outcome.open_loop[0])
            passed = int(outcome.verdict is Verdict.PASSED)  # only those passing judge the suite
            self.user_properties.append((OPEN_LOOP, f"{passed} {share!r} {self.spec.label}"))
        if outcome.result is not None:  # what it checked, as beatlog test's JUnit has it
            self.user_properties.extend(
                (f"beatlog_{name}", count) for name, count in outcome.result.counts.items()
            )
        try:
            updates = update_baselines([outcome], run.options.update)
            written = write_failed_variants([outcome])
        except BeatlogError as exc:  # a full disk: one line, as beatlog test says it
            pytest.fail(str(exc), pytrace=False)
        for line in [*render_updates(updates), *variant_lines(written)]:
            self.user_properties.append((UPDATE, line.plain))
        if outcome.verdict is Verdict.ERROR:
            shown = outcome.error_traceback if self.config.get_verbosity() > 0 else None
            pytest.fail(f"{outcome.error}\n{shown}" if shown else str(outcome.error), pytrace=False)

    def runtest(self) -> None:
        """Fail with the DTC's first divergence, and with what its audit found."""
        from beatlog.report.console import plain_text  # noqa: PLC0415
        from beatlog.report.suite import render_audit  # noqa: PLC0415 - see the imports

        outcome = self.outcome
        assert outcome is not None, "setup judges the DTC"
        failures = []
        if outcome.result is not None and not outcome.result.ok:
            failures.append(failure_text(outcome.result))
        if outcome.audit_findings:
            failures.append(plain_text(render_audit([outcome])))
        if failures:
            raise DtcFailedError("\n".join(failures))

    def repr_failure(
        self,
        excinfo: pytest.ExceptionInfo[BaseException],
        style: Any = None,
    ) -> str:
        if isinstance(excinfo.value, DtcFailedError):
            return str(excinfo.value)
        return str(super().repr_failure(excinfo, style=style))

    def reportinfo(self) -> tuple[Path, int, str]:
        return self.path, 0, f"dtc: {self.spec.label}"


@contextmanager
def quitting_as_pytest() -> Iterator[None]:
    """Quitting the debugger at a break ends the session as quitting pytest's pdb does
    (``pytest.exit``), not as a Ctrl-C."""
    try:
        yield
    except KeyboardInterrupt as stop:
        from beatlog.replay.debugger import DebuggerQuit  # noqa: PLC0415 - see the imports

        if isinstance(stop, DebuggerQuit):
            pytest.exit("Quitting debugger")
        raise


def failure_text(result: ReplayResult) -> str:
    from beatlog.report.console import plain_text, render_replay  # noqa: PLC0415

    return plain_text(render_replay(result))


@dataclass(eq=False)  # registered as a plugin: pluggy keeps plugins in sets
class BeatlogRun:
    """What this pytest run asks of its DTCs, and what they did, for the terminal summary."""

    options: SpecOptions
    """What each DTC is run with."""
    root: Path
    """pytest's rootdir: the coverage memory goes to its project root."""
    coverage: bool = False
    coverage_json: Path | None = None
    variants: int | None = None
    """Variants of each DTC that declares them; None: as many as each declares."""
    worker: bool = False
    """Whether this is an xdist worker's run: its DTCs' verdicts go to the controller's."""
    verdicts: list[Verdict] = field(default_factory=list)
    specs: set[Path] = field(default_factory=set)
    """The specs that ran: their folders are where orphaned baselines are looked for."""
    lines: list[str] = field(default_factory=list)
    """What updating the baselines did."""
    open_loop: list[tuple[bool, str, float]] = field(default_factory=list)
    """The DTCs judged against baselines whose behaviors left the recording: whether
    each passed, its label and the share of its cycles run open loop."""
    stale: StaleSuite | None = None
    """Whether the DTCs that ran are past the project's open-loop limits."""
    recorded: dict[Path, RecordedChanges] = field(default_factory=dict)
    """By spec, the state changes its log recorded, as its verdict's replay read them
    for the coverage (here; an xdist worker's DTCs' logs are read again for it)."""

    def pytest_collection_finish(self, session: pytest.Session) -> None:
        """A break at a cycle stops in one DTC: refuse a run that selects more, or one
        whose log ends before the break (as ``beatlog test`` does). The DTCs selected
        that share a name are named by their ids in what beatlog reports."""
        selected = [item for item in session.items if isinstance(item, DtcItem)]
        for item, spec in zip(selected, distinguished(item.spec for item in selected), strict=True):
            item.spec = spec
        break_at = self.options.break_at
        if break_at is None:
            return
        from beatlog.suite.selection import check_break_at  # noqa: PLC0415 - see the imports

        try:
            check_break_at(break_at, [item.spec for item in selected], option="--beatlog-break-at")
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
                passed, share, label = str(value).split(" ", 2)
                self.open_loop.append((passed == "1", label, float(share)))

    @pytest.hookimpl(tryfirst=True)
    def pytest_sessionfinish(self, session: pytest.Session) -> None:
        """Fail a run whose DTCs passed but are past the project's open-loop limits
        (``[tool.beatlog]`` ``max_open_loop_share``, ``max_open_loop_dtcs``), as
        ``beatlog test`` does."""
        if self.worker or not self.open_loop:
            return
        from beatlog.project.config import project_config  # noqa: PLC0415 - see the imports

        project = project_config(self.root)
        passed = [(label, share) for ok, label, share in self.open_loop if ok]
        self.stale = stale_suite(
            passed, max_share=project.max_open_loop_share, max_dtcs=project.max_open_loop_dtcs
        )
        if self.stale is not None and session.exitstatus == pytest.ExitCode.OK:
            session.exitstatus = pytest.ExitCode.TESTS_FAILED

    def pytest_terminal_summary(self, terminalreporter: pytest.TerminalReporter) -> None:
        """The pending baselines written, the orphans, the coverage and the DTCs' verdicts."""
        if not self.verdicts:
            return
        from beatlog.report.baselines import render_stale  # noqa: PLC0415 - see the imports
        from beatlog.report.counts import plural, verdict_counts  # noqa: PLC0415
        from beatlog.report.suite import plain_lines  # noqa: PLC0415

        report, problem = self._report()
        lines = [*self.lines, *plain_lines(report.orphan_lines())]
        if problem is not None:
            lines.append(f"beatlog: {problem}")
        lines.extend(f"beatlog: warning: {warning}" for warning in report.warnings)
        lines.extend(plain_lines(report.coverage_lines()))
        lines.extend(plain_lines(render_stale(self.stale)))
        if report.error is not None:
            lines.append(f"beatlog: warning: {report.error}")
        terminalreporter.section("beatlog")
        for line in lines:
            terminalreporter.write_line(line)
        counts = verdict_counts(self.verdicts, open_loop=len(self.open_loop))
        terminalreporter.write_line(f"{plural(len(self.verdicts), 'DTC')}: {counts}")

    def _report(self) -> tuple[SuiteReport, str | None]:
        """The end of the session, as ``beatlog test`` ends one (see
        :func:`beatlog.report.session.conclude`), for the specs that ran; with why there
        is no coverage where it was asked for and the specs could not be read again."""
        from beatlog.report.session import conclude  # noqa: PLC0415
        from beatlog.report.suite import SuiteReport  # noqa: PLC0415 - see the imports

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
