"""The audit report: each DTC's findings as a table, then one line counting them."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from beatlog.audit.replays import AuditReport, Finding, SeedRun
from beatlog.report.console import plain_text
from beatlog.report.suite import render_audit
from beatlog.suite.runner import SpecOutcome, run_spec
from beatlog.suite.spec import load_spec
from tests.conftest import RecordFn
from tests.specs import write_spec
from tests.text import whole_lines

RUNS = (SeedRun(1, True, 300, None, None, "ab"), SeedRun(2, True, 300, None, None, "ab"))
SOUND = AuditReport(findings=(), runs=RUNS, hash_seed_dependence=None)
LEAKY = dataclasses.replace(
    SOUND,
    findings=(
        Finding("time.monotonic", "behaviors.py:12 in Wander.step", 300),
        Finding("random.choice", "behaviors.py:20 in Wander.step", 1),
    ),
)
UNORDERED = dataclasses.replace(
    SOUND,
    hash_seed_dependence="the replay depends on the hash seed: PYTHONHASHSEED=1 passed, "
    "PYTHONHASHSEED=2 diverged at cycle 1 (state changes)",
)


@pytest.fixture
def outcome(tmp_path: Path, record_probe: RecordFn) -> SpecOutcome:
    return run_spec(load_spec(write_spec(tmp_path, "avoid-pole", record_probe(30))))


def audited(outcome: SpecOutcome, **reports: AuditReport) -> list[SpecOutcome]:
    return [
        dataclasses.replace(
            outcome, spec=dataclasses.replace(outcome.spec, name=name), audit=report
        )
        for name, report in reports.items()
    ]


def test_findings_name_the_dtc_each_call_its_site_and_count(outcome: SpecOutcome) -> None:
    text = plain_text(render_audit(audited(outcome, wander=LEAKY, dock=SOUND)), width=200)

    audits = [line for line in whole_lines(text) if line.startswith("AUDIT ")]
    assert audits == [f"AUDIT wander ({outcome.spec.path})"]  # dock's audit found nothing
    header = next(line for line in text.splitlines() if "┃" in line)
    assert [cell.strip() for cell in header.split("┃")[1:-1]] == ["call", "site", "calls"]
    rows = [" ".join(line.strip("│ ").split()) for line in text.splitlines() if "│" in line]
    assert rows == [
        "time.monotonic │ behaviors.py:12 in Wander.step │ 300",
        "random.choice │ behaviors.py:20 in Wander.step │ 1",
    ]
    assert text.rstrip().endswith("determinism audit: 2 findings in 1 of 2 DTCs")


def test_a_hash_seed_dependence_is_a_finding_too(outcome: SpecOutcome) -> None:
    text = plain_text(render_audit(audited(outcome, wander=LEAKY, heading=UNORDERED)), width=200)

    assert f"AUDIT heading ({outcome.spec.path})" in whole_lines(text)
    assert UNORDERED.hash_seed_dependence is not None
    assert UNORDERED.hash_seed_dependence in text
    assert text.rstrip().endswith("determinism audit: 3 findings in 2 of 2 DTCs")


def test_a_sound_suite_says_how_it_was_audited(outcome: SpecOutcome) -> None:
    text = plain_text(render_audit(audited(outcome, dock=SOUND)))

    assert (
        text
        == "determinism audit: no findings in 1 DTC (each replayed with PYTHONHASHSEED=1 and 2)\n"
    )


def test_outcomes_without_an_audit_render_nothing(outcome: SpecOutcome) -> None:
    assert plain_text(render_audit([outcome])) == ""
