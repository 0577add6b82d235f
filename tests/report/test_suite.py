"""A suite session's report: its lines in order, the notes of the passing DTCs, the
closing counts and the exit code; it never prints."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from rich.text import Text

from beatlog import replay
from beatlog.record.recorder import Recorder
from beatlog.replay.verdict import ReplayResult
from beatlog.report.console import plain_text
from beatlog.report.suite import NAMED_IN_NOTES, SuiteReport, plain_lines
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.spec import DtcSpec
from tests.conftest import PERIOD_NS, Probe, probe_system
from tests.specs import PROBE


@pytest.fixture(scope="module")
def result(tmp_path_factory: pytest.TempPathFactory) -> ReplayResult:
    """A pass of 30 cycles."""
    log = tmp_path_factory.mktemp("logs") / "probe.beatlog"
    with Recorder(log, probe_system(), seed=7, software="test") as recorder:
        for _ in range(30):
            recorder.step(PERIOD_NS, Probe(distance=2.0))
    return replay(log, probe_system())


def outcome(name: str, verdict: Verdict, result: ReplayResult | None, *notes: str) -> SpecOutcome:
    spec = DtcSpec(Path(f"{name}.dtc.toml"), name, "", (), Path("x.beatlog"), PROBE)
    if result is not None:
        result = dataclasses.replace(result, notes=notes)
    error = "no such file" if verdict is Verdict.ERROR else None
    return SpecOutcome(spec, verdict, result, error, 0.01)


def test_a_note_names_a_few_dtcs_then_counts_the_rest(result: ReplayResult) -> None:
    many = [
        outcome(f"dtc-{n}", Verdict.PASSED, result, "shared") for n in range(NAMED_IN_NOTES + 2)
    ]
    one = outcome("alone", Verdict.PASSED, result, "its own")
    failed = outcome("failed", Verdict.FAILED, result, "a failure's own report says it")

    report = SuiteReport(outcomes=(*many, one, failed))

    assert [line.plain for line in report.note_lines()] == [
        "note: 7 DTCs (dtc-0, dtc-1, dtc-2, dtc-3, dtc-4 and 2 more): shared",
        "note: alone: its own",
    ]


def test_the_closing_line_counts_verdicts_time_and_cycles(result: ReplayResult) -> None:
    report = SuiteReport(
        outcomes=(outcome("a", Verdict.PASSED, result), outcome("b", Verdict.ERROR, None)),
        selected=3,
        wall_s=1.5,
    )

    assert report.closing_line() == "1 passed, 0 failed, 1 error, 1 not run in 1.50 s (30 cycles)"
    assert SuiteReport().closing_line() == "0 passed, 0 failed in 0.00 s (0 cycles)"


@pytest.mark.parametrize(
    ("verdicts", "error", "code"),
    [
        ([Verdict.PASSED], None, 0),
        ([Verdict.PASSED, Verdict.FAILED], None, 1),
        ([Verdict.FAILED, Verdict.ERROR], None, 2),
        ([Verdict.PASSED], "report.xml: cannot write: No space left on device", 2),
    ],
    ids=["passed", "failed", "error", "unwritten-report"],
)
def test_the_exit_code_is_the_worst_of_what_happened(
    result: ReplayResult, verdicts: list[Verdict], error: str | None, code: int
) -> None:
    outcomes = tuple(
        outcome(f"dtc-{n}", verdict, None if verdict is Verdict.ERROR else result)
        for n, verdict in enumerate(verdicts)
    )

    assert SuiteReport(outcomes=outcomes, error=error).exit_code == code


def test_the_lines_go_summary_then_orphans(result: ReplayResult, tmp_path: Path) -> None:
    orphan = tmp_path / "gone.expected.json"
    report = SuiteReport(
        outcomes=(outcome("a", Verdict.PASSED, result, "noted"),), orphans=(orphan,)
    )

    text = [plain_text(line, width=200).rstrip("\n") for line in report.lines()]

    assert text[0].startswith("DTC suite")
    assert text[1:] == [
        "note: a: noted",
        f"orphaned baseline {orphan}: no spec beside it; delete it",
    ]


def test_a_report_of_nothing_has_no_lines() -> None:
    assert SuiteReport().lines() == []


def test_plain_lines_keep_a_line_whole_and_draw_a_table(result: ReplayResult) -> None:
    long = Text("x" * 150)
    table = SuiteReport(outcomes=(outcome("a", Verdict.PASSED, result),)).summary()[0]

    lines = plain_lines([long, table])

    assert lines[0] == "x" * 150
    assert lines[1:] == plain_text(table).splitlines()
