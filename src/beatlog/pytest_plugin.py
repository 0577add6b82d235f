"""The pytest plugin: DTC specs become test items, and a fixture replays logs in tests.

Registered under the ``pytest11`` entry point, so installing beatlog is enough:
``pytest`` collects every ``*.dtc.toml`` file as one test named after the spec. Set
``beatlog_collect = false`` in the pytest ini options to turn collection off. DTC
items carry the ``dtc`` marker, and ``-k`` matches their names and tags. A DTC is
judged in its item's setup: one that cannot run (its log or system is bad input,
``beatlog test``'s error) is an ERROR, one that diverges fails.

Options (the ``beatlog`` group; the default is neither): ``--beatlog-update`` writes
the new expectation of each failing DTC to its pending baseline for review, as
``beatlog test --update`` does, and never when ``CI`` is set; ``--beatlog-audit``
also audits each DTC's determinism and fails the ones it finds leaking;
``--beatlog-coverage`` shows the transition coverage of the DTCs that ran, as
``beatlog test --coverage`` does (remembering what earlier runs saw), and
``--beatlog-coverage-json FILE`` writes it for tools. The terminal summary says what
was written, names orphaned baselines and counts the verdicts.

Break points, as ``beatlog replay`` has them: ``--beatlog-break-at CYCLE`` stops in the
debugger just before the behaviors update in that cycle of the one DTC selected (with
``-k`` or its path), ``--beatlog-break-on-divergence`` replays each failing DTC again
and stops at its first divergence. They stop as ``beatlog replay`` does
(:mod:`beatlog.replay.debugger`): ``PYTHONBREAKPOINT`` is honoured, pytest suspends its
output capture while pdb runs, and quitting pdb ends the session as quitting pytest's
pdb does (pytest's pdb is built on :class:`~beatlog.replay.debugger.Debugger` for that,
unless ``--pdbcls`` names another). A break past the end of the selected DTC's log is a
usage error. They need the DTCs run in the pytest process (no ``-n`` of pytest-xdist).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from beatlog.errors import BeatlogError, OptionError, SpecError
from beatlog.suite.discovery import discover_specs, distinguished
from beatlog.suite.policy import SpecOptions, UpdateMode
from beatlog.suite.spec import SPEC_SUFFIX, DtcSpec, load_spec

if TYPE_CHECKING:
    from beatlog.model.behavior import System
    from beatlog.replay.verdict import ReplayResult
    from beatlog.report.suite import SuiteReport
    from beatlog.suite.runner import SpecOutcome, Verdict

# The engines and reports are imported where a DTC runs or the summary is written: every
# pytest process loads this plugin (each xdist worker too), most of them to run no DTC.

__all__ = ["DtcFile", "DtcItem", "beatlog_replay"]

_VERDICT, _SPEC, _UPDATE = "beatlog_verdict", "beatlog_spec", "beatlog_update"
_OPEN_LOOP = "beatlog_open_loop"
"""Names of the user properties a DTC's report carries to the summary (across xdist)."""


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("beatlog", "beatlog deterministic test cases (*.dtc.toml)")
    group.addoption(
        "--beatlog-update",
        action="store_const",
        const=UpdateMode.NEW.value,
        default=UpdateMode.NONE.value,
        dest="beatlog_update",
        help="write the new expectation of each failing DTC to its pending baseline for "
        "review (beatlog review, beatlog approve); never when CI is set",
    )
    group.addoption(
        "--beatlog-audit",
        action="store_true",
        dest="beatlog_audit",
        help="also replay each DTC twice with different hash seeds, watching for wall-clock "
        "reads and global random calls; a DTC with findings fails",
    )
    group.addoption(
        "--beatlog-coverage",
        action="store_true",
        dest="beatlog_coverage",
        help="show which behavior states and transitions the DTCs that ran exercise, and the "
        "states declared or seen by earlier runs that none reaches",
    )
    group.addoption(
        "--beatlog-coverage-json",
        type=Path,
        metavar="FILE",
        dest="beatlog_coverage_json",
        help="write the transition coverage of the DTCs that ran as JSON",
    )
    group.addoption(
        "--beatlog-break-at",
        type=int,
        metavar="CYCLE",
        dest="beatlog_break_at",
        help="stop in the debugger just before the behaviors update in this cycle of the "
        "one DTC selected",
    )
    group.addoption(
        "--beatlog-break-on-divergence",
        action="store_true",
        dest="beatlog_break_on_divergence",
        help="replay each failing DTC again and stop in the debugger at its first divergence",
    )
    parser.addini(
        "beatlog_collect",
        type="bool",
        default=True,
        help="collect *.dtc.toml files as beatlog deterministic test cases",
    )


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
    verdicts: list[Verdict] = field(default_factory=list)
    specs: set[Path] = field(default_factory=set)
    """The specs that ran: their folders are where orphaned baselines are looked for."""
    lines: list[str] = field(default_factory=list)
    """What updating the baselines did."""
    open_loop: int = 0
    """The DTCs judged against baselines whose behaviors left the recording."""

    @property
    def options(self) -> SpecOptions:
        """What each DTC is run with."""
        return SpecOptions(
            update=self.update,
            audit=self.audit,
            break_at=self.break_at,
            break_on_divergence=self.break_on_divergence,
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
            if name == _VERDICT:
                self.verdicts.append(Verdict(str(value)))
            elif name == _SPEC:
                self.specs.add(Path(str(value)))
            elif name == _UPDATE:
                self.lines.append(str(value))
            elif name == _OPEN_LOOP:
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
        )
        return report, problem


_RUN = pytest.StashKey[BeatlogRun]()


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "dtc: a beatlog deterministic test case (*.dtc.toml)")
    break_at = config.getoption("beatlog_break_at")
    break_on_divergence = config.getoption("beatlog_break_on_divergence")
    if break_at is not None and break_at < 0:
        raise pytest.UsageError(f"--beatlog-break-at: must be 0 or more, got {break_at}")
    if break_at is not None or break_on_divergence:
        if _distributed(config):
            raise pytest.UsageError(
                "the beatlog break points stop in the debugger of this process: "
                "run without pytest-xdist's -n (or with -n 0)"
            )
        if config.option.usepdb_cls is None:  # pytest's pdb, quitting wherever it stops
            config.option.usepdb_cls = ("beatlog.replay.debugger", "Debugger")
    coverage_json = config.getoption("beatlog_coverage_json")
    config.stash[_RUN] = BeatlogRun(
        update=UpdateMode.parse(config.getoption("beatlog_update")),
        audit=config.getoption("beatlog_audit"),
        root=config.rootpath,
        coverage=config.getoption("beatlog_coverage"),
        coverage_json=None
        if coverage_json is None
        else config.invocation_params.dir / coverage_json,
        break_at=break_at,
        break_on_divergence=break_on_divergence,
    )
    config.pluginmanager.register(config.stash[_RUN], "beatlog-run")


def _distributed(config: pytest.Config) -> bool:
    """Whether pytest-xdist runs the tests in worker processes."""
    return bool(getattr(config.option, "numprocesses", None)) and (
        getattr(config.option, "dist", "no") != "no"
    )


def pytest_collect_file(parent: pytest.Collector, file_path: Path) -> pytest.Collector | None:
    if file_path.name.endswith(SPEC_SUFFIX) and parent.config.getini("beatlog_collect"):
        return DtcFile.from_parent(parent, path=file_path)
    return None


class DtcFailedError(AssertionError):
    """A DTC that diverged; carries the text pytest shows."""


class DtcFile(pytest.File):
    """A ``*.dtc.toml`` spec file: one test item."""

    def collect(self) -> Iterator[pytest.Item]:
        try:
            spec = load_spec(self.path, rootdir=self.config.rootpath)
        except SpecError as exc:
            raise self.CollectError(str(exc)) from None
        yield DtcItem.from_parent(self, name=spec.name, spec=spec)


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
        from beatlog.suite.maintenance import update_baselines  # noqa: PLC0415
        from beatlog.suite.runner import Verdict, run_spec  # noqa: PLC0415

        run = self.config.stash[_RUN]
        with _quitting_as_pytest():
            outcome = self.outcome = run_spec(self.spec, run.options)
        self.user_properties.append((_VERDICT, outcome.verdict.value))
        self.user_properties.append((_SPEC, str(self.spec.path)))
        if outcome.open_loop is not None:
            self.user_properties.append((_OPEN_LOOP, outcome.open_loop[0]))
        if outcome.result is not None:  # what it checked, as beatlog test's JUnit has it
            self.user_properties.extend(
                (f"beatlog_{name}", count) for name, count in outcome.result.counts.items()
            )
        for line in render_updates(update_baselines([outcome], run.update)):
            self.user_properties.append((_UPDATE, line.plain))
        if outcome.verdict is Verdict.ERROR:
            shown = outcome.error_traceback if self.config.get_verbosity() > 0 else None
            pytest.fail(f"{outcome.error}\n{shown}" if shown else str(outcome.error), pytrace=False)

    def runtest(self) -> None:
        """Fail with the DTC's first divergence, and with what its audit found."""
        from beatlog.report.audit import render_audit  # noqa: PLC0415 - see the imports
        from beatlog.report.console import plain_text  # noqa: PLC0415

        outcome = self.outcome
        assert outcome is not None, "setup judges the DTC"
        failures = []
        if outcome.result is not None and not outcome.result.ok:
            failures.append(_failure_text(outcome.result))
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
def _quitting_as_pytest() -> Iterator[None]:
    """Quitting the debugger at a break ends the session as quitting pytest's pdb does
    (``pytest.exit``), not as a Ctrl-C."""
    try:
        yield
    except KeyboardInterrupt as stop:
        from beatlog.replay.debugger import DebuggerQuit  # noqa: PLC0415 - see the imports

        if isinstance(stop, DebuggerQuit):
            pytest.exit("Quitting debugger")
        raise


def _failure_text(result: ReplayResult) -> str:
    from beatlog.report.console import plain_text, render_replay  # noqa: PLC0415

    return plain_text(render_replay(result))


@pytest.fixture
def beatlog_replay(request: pytest.FixtureRequest) -> Callable[..., ReplayResult]:
    """Replay a session log in an ordinary test; a divergence fails the test readably.

    ``beatlog_replay(log, system, **options)`` takes the same arguments as
    :func:`beatlog.replay` and returns its result when the replay passes. A relative
    ``log`` is found beside the test file, as a spec's is beside the spec, and a
    ``module:factory`` system also imports from the test's folder and project root. A
    log that cannot be read (missing, corrupt, not fitting the system) fails the test
    with one line naming the file.
    """

    def run(log: str | Path, system: System | str, **options: Any) -> ReplayResult:
        from beatlog.replay.judge import replay  # noqa: PLC0415 - see the imports
        from beatlog.usercode import importable_near  # noqa: PLC0415

        try:
            with importable_near(request.path), _quitting_as_pytest():
                result = replay(request.path.parent / log, system, **options)
        except BeatlogError as exc:
            pytest.fail(str(exc), pytrace=False)
        if not result.ok:
            pytest.fail(_failure_text(result), pytrace=False)
        return result

    return run
