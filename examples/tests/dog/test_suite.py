"""The committed 22-DTC suite: it passes, and a change to any single behavior fails it."""

from __future__ import annotations

import pytest

from beatlog import replay
from beatlog.analysis.summary import summarize
from beatlog.log.reader import LogStatus
from beatlog.suite.discovery import discover_specs
from beatlog.suite.parallel import run_suite
from beatlog.suite.runner import Verdict
from beatlog_examples.dog import SUITE_DIR
from beatlog_examples.dog.behaviors import CHANGES, changed_system
from beatlog_examples.dog.scenarios import SUITE

SPECS = discover_specs([SUITE_DIR])
SHORTEST_FIRST = sorted(SPECS, key=lambda spec: spec.log.stat().st_size)


@pytest.mark.slow  # reads every committed log through
def test_the_suite_has_a_spec_and_a_log_for_every_scenario_within_20_mb() -> None:
    assert sorted(spec.name for spec in SPECS) == sorted(case.name for case in SUITE)
    assert sum(spec.log.stat().st_size for spec in SPECS) <= 20 * 2**20
    for spec in SPECS:
        summary = summarize(spec.log)
        assert 30.0 <= summary.robot_time_ns / 1e9 <= 180.5, spec.name
        assert summary.status == LogStatus(complete=True, cycles=summary.cycles), spec.name


@pytest.mark.slow
def test_every_dtc_passes_against_the_current_behaviors() -> None:
    outcomes = run_suite(SPECS)
    assert [o.spec.name for o in outcomes if o.verdict is not Verdict.PASSED] == []


@pytest.mark.parametrize(
    "behavior",
    [
        # the costliest: noticed only after replaying many of the DTCs
        pytest.param(name, marks=pytest.mark.slow) if name in {"recharge", "sleep"} else name
        for name in sorted(CHANGES)
    ],
)
def test_a_change_to_any_single_behavior_fails_at_least_one_dtc(behavior: str) -> None:
    for spec in SHORTEST_FIRST:
        result = replay(spec.log, changed_system(behavior), context_cycles=0)
        if not result.ok:
            assert result.divergence is not None
            return
    pytest.fail(f"no DTC notices a change to {behavior}: {CHANGES[behavior]}")
