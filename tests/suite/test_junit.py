"""JUnit XML for CI: one testcase per DTC, a failure with the first divergence, errors apart."""

from __future__ import annotations

import dataclasses
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from beatlog.audit.replays import AuditReport, Finding, SeedRun
from beatlog.report.console import plain_text, render_replay
from beatlog.suite.junit import write_junit
from beatlog.suite.runner import SpecOutcome, run_spec
from beatlog.suite.spec import load_spec
from tests.conftest import RecordFn
from tests.specs import CHANGED, FIRST_CHANGED_CYCLE, PROBE, write_spec
from tests.text import whole_lines


def describe(outcome: SpecOutcome) -> str:
    """The failure text a person reads in CI: the replay report, as the CLI prints it."""
    assert outcome.result is not None
    return plain_text(render_replay(outcome.result))


@pytest.fixture
def outcomes(tmp_path: Path, record_probe: RecordFn) -> list[SpecOutcome]:
    """A pass, a failure and an error, in that order."""
    log = record_probe(300)
    specs = tmp_path / "specs"
    return [
        run_spec(load_spec(write_spec(specs, "avoid-pole", log))),
        run_spec(load_spec(write_spec(specs, "avoid-pole-earlier", log, CHANGED))),
        run_spec(load_spec(write_spec(specs, "lost", tmp_path / "lost.beatlog", PROBE))),
    ]


@pytest.fixture
def report(tmp_path: Path, outcomes: list[SpecOutcome]) -> Path:
    """The JUnit report of :func:`outcomes`."""
    path = tmp_path / "report.xml"
    write_junit(path, outcomes, describe=describe)
    return path


def read_report(path: Path) -> ET.Element:
    return ET.parse(path).getroot()


def test_the_testsuite_counts_tests_failures_and_errors(
    outcomes: list[SpecOutcome], report: Path
) -> None:
    suite = read_report(report)
    assert report.read_bytes().startswith(b"<?xml version='1.0' encoding='utf-8'?>")
    assert suite.tag == "testsuite"
    assert suite.get("name") == "beatlog"
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors")) == ("3", "1", "1")
    assert float(suite.get("time", "")) == pytest.approx(
        sum(o.wall_time_s for o in outcomes), abs=0.002
    )


def test_each_dtc_is_one_testcase_named_after_its_spec(
    tmp_path: Path, outcomes: list[SpecOutcome], report: Path
) -> None:
    cases = read_report(report).findall("testcase")
    assert [case.get("name") for case in cases] == ["avoid-pole", "avoid-pole-earlier", "lost"]
    assert [case.get("file") for case in cases] == [str(o.spec.path) for o in outcomes]
    assert {case.get("classname") for case in cases} == {str(tmp_path / "specs")}
    assert [child.tag for child in cases[0]] == ["properties"]  # neither failure nor error


def test_a_dtc_that_ran_carries_what_it_checked_as_properties(report: Path) -> None:
    cases = read_report(report).findall("testcase")
    properties = [
        {item.get("name"): item.get("value") for item in case.iter("property")} for case in cases
    ]
    assert properties[0] == {
        "beatlog_cycles": "300",
        "beatlog_state_changes": "45",
        "beatlog_outputs": "453",
        "beatlog_draws": "60",
        "beatlog_samples": "0",
    }
    assert properties[1]["beatlog_cycles"] == str(FIRST_CHANGED_CYCLE + 1)  # up to the divergence
    assert properties[2] == {}  # an error ran nothing


def test_a_failure_carries_the_divergence_message_and_the_full_report(
    outcomes: list[SpecOutcome], report: Path
) -> None:
    case = read_report(report).findall("testcase")[1]
    failure = case.find("failure")
    assert failure is not None
    assert case.find("error") is None
    assert failure.get("message") == "behavior state changes differ from the recording"
    assert failure.text is not None
    assert (
        f"first divergence: cycle {FIRST_CHANGED_CYCLE}, t = 0.660 s, state changes"
        in whole_lines(failure.text)
    )
    reproduce = f"reproduce: beatlog test {outcomes[1].spec.path}"
    assert reproduce in " ".join(failure.text.split())  # plain_text wraps at 100 columns


def test_an_error_carries_the_reason_the_dtc_could_not_run(
    outcomes: list[SpecOutcome], report: Path
) -> None:
    case = read_report(report).findall("testcase")[2]
    error = case.find("error")
    assert error is not None
    assert case.find("failure") is None
    assert error.get("message") == (
        f"{outcomes[2].spec.log}: no such file (a spec's log is relative to its folder)"
    )
    assert error.text == error.get("message")


def test_markup_characters_in_names_and_messages_survive(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(30)
    odd = run_spec(load_spec(write_spec(tmp_path, "pole", log, 'x<&>"y:system', name='<&> "pole"')))
    report = tmp_path / "report.xml"

    write_junit(report, [odd], describe=describe)

    case = read_report(report).findall("testcase")[0]
    error = case.find("error")
    assert case.get("name") == '<&> "pole"'
    assert error is not None
    assert odd.error is not None
    assert re.fullmatch(
        r"'x<&>\"y:system': cannot import x<&>\"y: No module named 'x<&>\"y' "
        rf"\(looked in {re.escape(str(tmp_path))}, .+ and the installed packages; .+\)",
        odd.error,
    ), odd.error
    assert error.get("message") == odd.error


def test_the_report_folder_is_created_as_ci_configurations_expect(
    tmp_path: Path, outcomes: list[SpecOutcome]
) -> None:
    report = tmp_path / "reports" / "dtc" / "junit.xml"

    write_junit(report, outcomes, describe=describe)

    assert len(read_report(report).findall("testcase")) == 3


def test_an_empty_run_is_an_empty_testsuite(tmp_path: Path) -> None:
    report = tmp_path / "report.xml"

    write_junit(report, [], describe=describe)

    suite = read_report(report)
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors")) == ("0", "0", "0")
    assert suite.findall("testcase") == []


# the determinism audit

UNSOUND = AuditReport(
    findings=(Finding("time.monotonic", "behaviors.py:12 in Wander.step", 300),),
    runs=(SeedRun(1, True, 300, None, None, "ab"), SeedRun(2, True, 300, None, None, "ab")),
    hash_seed_dependence="the replay depends on the hash seed: ...",
)
SOUND = dataclasses.replace(UNSOUND, findings=(), hash_seed_dependence=None)


def test_audit_findings_are_a_failure_of_their_own(
    tmp_path: Path, outcomes: list[SpecOutcome]
) -> None:
    passed, failed, error = outcomes
    audited = [
        dataclasses.replace(passed, audit=UNSOUND),
        dataclasses.replace(failed, audit=UNSOUND),
        error,
        dataclasses.replace(passed, audit=SOUND),
    ]
    report = tmp_path / "report.xml"

    write_junit(report, audited, describe=describe)

    suite = read_report(report)
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors")) == ("4", "2", "1")
    cases = suite.findall("testcase")
    (finding,) = cases[0].findall("failure")
    assert finding.get("type") == "determinism audit"
    assert finding.get("message") == "determinism audit: 2 findings"
    assert finding.text == (
        "time.monotonic at behaviors.py:12 in Wander.step (300 times)\n"
        "the replay depends on the hash seed: ..."
    )
    assert [f.get("type") for f in cases[1].findall("failure")] == [None, "determinism audit"]
    assert [child.tag for child in cases[3]] == ["properties"]  # a sound audit adds nothing
