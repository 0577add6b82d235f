"""The suite runner: one verdict per spec, in spec order, here or in worker processes."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Iterable
from pathlib import Path

import pytest

from beatlog.suite.parallel import run_suite
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.spec import DtcSpec
from beatlog.suite.variants import with_variants
from tests.conftest import MEETING, RecordFn
from tests.specs import CHANGED, FIRST_CHANGED_CYCLE, written_dtc


@pytest.fixture
def log(record_probe: RecordFn) -> Path:
    return record_probe(300)


def verdicts(outcomes: Iterable[SpecOutcome]) -> list[tuple[str, Verdict]]:
    return [(outcome.spec.name, outcome.verdict) for outcome in outcomes]


@pytest.fixture
def mixed_suite(tmp_path: Path, log: Path) -> list[DtcSpec]:
    """Five specs in path order: two pass, two fail, one cannot run."""
    specs = tmp_path / "specs"
    return [
        written_dtc(specs, "a-pass", log),
        written_dtc(specs, "b-fail", log, CHANGED),
        written_dtc(specs, "c-error", tmp_path / "lost.beatlog"),
        written_dtc(specs, "d-pass", log),
        written_dtc(specs, "e-fail", log, CHANGED),
    ]


EXPECTED = [
    ("a-pass", Verdict.PASSED),
    ("b-fail", Verdict.FAILED),
    ("c-error", Verdict.ERROR),
    ("d-pass", Verdict.PASSED),
    ("e-fail", Verdict.FAILED),
]


def test_a_suite_gives_one_outcome_per_spec_in_spec_order(mixed_suite: list[DtcSpec]) -> None:
    seen: list[SpecOutcome] = []

    outcomes = run_suite(mixed_suite, on_outcome=seen.append)

    assert verdicts(outcomes) == EXPECTED
    assert seen == outcomes


def test_worker_processes_give_the_same_verdicts_in_spec_order(
    mixed_suite: list[DtcSpec],
) -> None:
    seen: list[SpecOutcome] = []

    sequential = run_suite(mixed_suite, jobs=1)
    parallel = run_suite(mixed_suite, jobs=2, on_outcome=seen.append)

    assert verdicts(parallel) == verdicts(sequential) == EXPECTED
    assert [o.spec for o in parallel] == mixed_suite
    assert sorted(verdicts(seen)) == EXPECTED  # once per spec, in the order they finished
    failed = parallel[1].result
    assert failed is not None
    assert failed.divergence is not None
    assert failed.divergence.cycle == FIRST_CHANGED_CYCLE
    assert parallel[2].error == sequential[2].error


def test_an_empty_suite_runs_nothing() -> None:
    assert run_suite([], jobs=4) == []


def test_fail_fast_stops_after_the_first_failure(mixed_suite: list[DtcSpec]) -> None:
    seen: list[SpecOutcome] = []

    outcomes = run_suite(mixed_suite, fail_fast=True, on_outcome=seen.append)

    assert verdicts(outcomes) == [("a-pass", Verdict.PASSED), ("b-fail", Verdict.FAILED)]
    assert seen == outcomes


def test_fail_fast_also_stops_at_an_error(mixed_suite: list[DtcSpec]) -> None:
    without_failures = [spec for spec in mixed_suite if "fail" not in spec.name]

    outcomes = run_suite(without_failures, fail_fast=True)

    assert verdicts(outcomes) == [("a-pass", Verdict.PASSED), ("c-error", Verdict.ERROR)]


def test_fail_fast_in_workers_gives_every_outcome_that_came_back_in_spec_order(
    mixed_suite: list[DtcSpec],
) -> None:
    seen: list[SpecOutcome] = []

    outcomes = run_suite(mixed_suite, jobs=2, fail_fast=True, on_outcome=seen.append)

    assert sorted(verdicts(seen)) == sorted(verdicts(outcomes))
    finished = {o.spec.path for o in seen}
    assert [o.spec for o in outcomes] == [s for s in mixed_suite if s.path in finished]
    assert any(o.verdict is not Verdict.PASSED for o in outcomes)


def test_with_two_jobs_specs_run_here_and_in_a_worker_at_once(
    tmp_path: Path, log: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two specs that finish only when they run at the same time, in two processes."""
    meeting = tmp_path / "meeting"
    meeting.mkdir()
    monkeypatch.setenv(MEETING, str(meeting))
    suite = [
        written_dtc(tmp_path, name, log, "tests.conftest:meeting_system") for name in ("a", "b")
    ]

    outcomes = run_suite(suite, jobs=2)

    assert verdicts(outcomes) == [("a", Verdict.PASSED), ("b", Verdict.PASSED)]
    pids = {int(sign.name) for sign in meeting.iterdir()}
    assert len(pids) == 2
    assert os.getpid() in pids


def test_variants_spread_over_worker_processes_each_with_its_own_outcome(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(100, start_time_ns=1_700_000_000_000_000_000)  # its variants keyed
    spec = written_dtc(
        tmp_path, "dock", log, "tests.systems:fussy_system", variants={"noise": {"distance": 0.05}}
    )
    suite = with_variants([spec], 4)

    sequential = run_suite(suite, jobs=1)
    parallel = run_suite(suite, jobs=2)

    assert [o.spec.id for o in parallel] == [spec.id for spec in suite]
    assert [(o.verdict, o.result) for o in parallel] == [
        (o.verdict, dataclasses.replace(o.result, wall_time_s=p.result.wall_time_s))
        for o, p in zip(sequential, parallel, strict=True)
        if o.result is not None and p.result is not None
    ]
    assert Verdict.FAILED in {o.verdict for o in parallel}
