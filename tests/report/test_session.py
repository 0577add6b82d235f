"""The suite session every shell runs: select, run, update, report; what it did comes
back as a report that prints nothing."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import pytest

from beatlog.baseline.file import expected_path, pending_path, read_baseline
from beatlog.baseline.policy import UpdateMode
from beatlog.errors import OptionError
from beatlog.report.session import SuiteSession, conclude, prepare_report
from beatlog.report.suite import SuiteReport
from beatlog.suite.coverage import cache_path, suite_coverage
from beatlog.suite.discovery import discover_specs
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.selection import SuiteOptions
from beatlog.suite.spec import load_spec
from tests.conftest import RecordFn
from tests.factories import fill_the_disk_after, opened_logs
from tests.specs import CHANGED, FIRST_CHANGED_CYCLE, write_spec


def _run_session(
    options: SuiteOptions, on_outcome: Callable[[SpecOutcome], object] | None = None
) -> SuiteReport:
    """Select, run and report a suite as ``beatlog test`` does."""
    session = SuiteSession(options)
    session.run(on_outcome)
    return session.finish()


@pytest.fixture
def specs(tmp_path: Path, record_probe: RecordFn) -> Path:
    """A folder of two DTCs of one 300-cycle log: one passes, ``changed`` fails."""
    log = record_probe(300)
    folder = tmp_path / "specs"
    write_spec(folder, "approach", log)
    write_spec(folder, "changed", log, CHANGED)
    return folder


def test_a_session_runs_the_dtcs_and_writes_the_reports_printing_nothing(
    specs: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    junit, coverage = tmp_path / "reports" / "junit.xml", tmp_path / "coverage.json"
    seen: list[SpecOutcome] = []

    report = _run_session(
        SuiteOptions(paths=(specs,), jobs=1, junit_xml=junit, coverage_json=coverage),
        on_outcome=seen.append,
    )

    assert [(o.spec.name, o.verdict) for o in report.outcomes] == [
        ("approach", Verdict.PASSED),
        ("changed", Verdict.FAILED),
    ]
    assert seen == list(report.outcomes)
    assert (report.selected, report.not_run) == (2, 0)
    assert report.cycles == 300 + FIRST_CHANGED_CYCLE + 1, "the failure stops at its divergence"
    assert report.exit_code == 1
    assert report.written == (junit, coverage)
    assert ET.parse(junit).getroot().get("failures") == "1"
    assert report.coverage is not None
    assert not report.shows_coverage
    assert cache_path(specs).is_file()
    assert (report.error, report.warnings, report.interrupted) == (None, (), None)
    assert capsys.readouterr() == ("", "")


def test_an_update_writes_the_failures_pending_baselines(specs: Path) -> None:
    report = _run_session(SuiteOptions(paths=(specs,), jobs=1, update=UpdateMode.NEW))

    assert [(update.spec.name, update.path) for update in report.updates] == [
        ("changed", pending_path(specs / "changed.dtc.toml"))
    ]
    assert pending_path(specs / "changed.dtc.toml").is_file()


def test_a_full_disk_stops_the_update_in_one_line_keeping_what_was_written_whole(
    specs: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    write_spec(specs, "later-change", load_spec(specs / "changed.dtc.toml").log, CHANGED)
    fill_the_disk_after(monkeypatch, files=1)

    report = _run_session(SuiteOptions(paths=(specs,), jobs=1, update=UpdateMode.NEW))

    written = pending_path(specs / "changed.dtc.toml")
    unwritten = pending_path(specs / "later-change.dtc.toml")
    assert report.error == f"{unwritten}: cannot write: No space left on device"
    assert report.exit_code == 2
    assert read_baseline(written).whole.changes
    assert sorted(path.name for path in specs.iterdir() if "pending" in path.name) == [written.name]


def test_the_session_selects_before_anything_runs(specs: Path) -> None:
    session = SuiteSession(SuiteOptions(paths=(specs,), pattern="approach"))

    assert [spec.name for spec in session.specs] == ["approach"]
    assert session.outcomes == []


def test_an_interrupted_run_keeps_what_was_complete_and_writes_nothing(
    specs: Path, tmp_path: Path
) -> None:
    junit = tmp_path / "junit.xml"
    session = SuiteSession(SuiteOptions(paths=(specs,), jobs=1, junit_xml=junit))

    def stop(outcome: SpecOutcome) -> None:
        raise KeyboardInterrupt

    ran = session.run(stop)
    report = session.finish()

    assert isinstance(report.interrupted, KeyboardInterrupt)
    assert ran.interrupted is report.interrupted
    assert [outcome.spec.name for outcome in report.outcomes] == ["approach"]
    assert (report.not_run, report.written) == (1, ())
    assert not junit.exists()


def test_a_report_that_cannot_be_written_stops_the_writing(specs: Path, tmp_path: Path) -> None:
    reports = tmp_path / "reports"
    junit, html = reports / "junit.xml", tmp_path / "report.html"
    session = SuiteSession(SuiteOptions(paths=(specs,), jobs=1, junit_xml=junit, html=html))
    reports.rmdir()
    reports.write_text("a file where the folder was")
    session.run()

    report = session.finish()

    assert report.error == f"{junit}: cannot write: File exists"
    assert report.exit_code == 2
    assert report.written == ()
    assert not html.exists()


def test_a_report_that_cannot_be_written_is_refused_before_the_run(tmp_path: Path) -> None:
    folder = tmp_path / "junit.xml"
    folder.mkdir()
    under_a_file = tmp_path / "file" / "deeper" / "junit.xml"
    under_a_file.parent.parent.write_text("a file where a folder goes")

    with pytest.raises(OptionError) as directory:
        prepare_report(folder)
    with pytest.raises(OptionError) as file_as_folder:
        prepare_report(under_a_file)

    assert str(directory.value) == f"{folder}: is a directory"
    assert str(file_as_folder.value) == f"{under_a_file}: {tmp_path / 'file'} is not a directory"


def test_prepare_report_makes_the_report_s_folder(tmp_path: Path) -> None:
    report = tmp_path / "deep" / "er" / "junit.xml"

    prepare_report(report)

    assert report.parent.is_dir()


def test_conclude_names_orphans_and_remembers_the_coverage_of_what_ran(specs: Path) -> None:
    orphan = expected_path(specs / "gone.dtc.toml")
    orphan.write_text("{}")
    found = discover_specs([specs])

    report = conclude(
        SuiteReport(), found[:1], found=found, root=specs, orphans_in=[specs], coverage=True
    )

    assert report.orphans == (orphan,)
    assert report.coverage is not None
    assert report.coverage.dtcs == [found[0].id]
    assert report.shows_coverage
    assert cache_path(specs).is_file()


def test_conclude_measures_nothing_unless_asked(specs: Path) -> None:
    found = discover_specs([specs])

    report = conclude(SuiteReport(), found, found=found, root=specs, orphans_in=[specs])

    assert (report.orphans, report.coverage, report.written) == ((), None, ())
    assert not cache_path(specs).exists()


def test_a_run_with_coverage_reads_each_log_once_and_measures_what_the_logs_hold(
    specs: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from_logs = suite_coverage(discover_specs([specs]))
    opened = opened_logs(monkeypatch)

    report = _run_session(SuiteOptions(paths=(specs,), jobs=1, coverage=True))

    assert report.coverage is not None
    assert report.coverage.to_json() == from_logs.to_json()
    assert [o.recorded is not None for o in report.outcomes] == [True, True]
    assert opened == ["probe.beatlog"] * 4  # each DTC's verdict, the failure's repeat and details
