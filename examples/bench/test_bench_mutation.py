"""The mutation bench on a toy behavior: the mutants it makes, and how each one fares
against a DTC recorded from the unmutated toy."""

from __future__ import annotations

import importlib.util
from collections.abc import Sequence
from pathlib import Path

import pytest

from beatlog.model.clock import DEFAULT_PERIOD_NS
from beatlog.record.recorder import Recorder
from beatlog.suite.spec import spec_text
from bench_mutation import Mutant, Outcome, Target, Workers, mutants, run_mutant

TOY = '''"""An alarm that rings while the level is above half."""

from beatlog.model.behavior import PriorityArbiter
from beatlog.model.state import RobotState


class Gauge(RobotState, kw_only=True):
    level: float


class Alarm:
    name = "alarm"

    def __init__(self):
        self.state = "quiet"

    def step(self, rs, ctx):
        self.state = "ringing" if rs.level > 0.5 else "quiet"
        return None


def system():
    return PriorityArbiter([Alarm()], robot_state=Gauge)
'''


@pytest.fixture
def toy(tmp_path: Path) -> Target:
    path = tmp_path / "toy_alarm.py"
    path.write_text(TOY, encoding="utf-8")
    return Target("toy", "toy_alarm", path)


def record_toy(toy: Target, levels: Sequence[float]) -> Path:
    """A DTC of the unmutated toy fed ``levels``; returns the spec's path."""
    found = importlib.util.spec_from_file_location(toy.module, toy.path)
    assert found is not None
    assert found.loader is not None
    module = importlib.util.module_from_spec(found)
    found.loader.exec_module(module)
    log = toy.path.with_name("toy.beatlog")
    with Recorder(log, module.system(), seed=1, software="test") as recorder:
        for level in levels:
            recorder.step(DEFAULT_PERIOD_NS, module.Gauge(level=level))
    spec = log.with_name("toy.dtc.toml")
    spec.write_text(
        spec_text(
            name="toy",
            purpose="The alarm rings while the level is above half.",
            procedure=["Raise and lower the level."],
            log=log.name,
            system="toy_alarm:system",
        ),
        encoding="utf-8",
    )
    return spec


def fates(toy: Target, spec: Path) -> dict[str, Outcome]:
    with Workers(1) as workers:
        return {
            mutant.description: run_mutant(mutant, [spec], workers).outcome
            for mutant in mutants(toy)
        }


def test_the_toy_has_three_mutants_named_by_place_and_change(toy: Target) -> None:
    found: list[Mutant] = mutants(toy)

    assert [(m.where, m.description) for m in found] == [
        ("toy_alarm.py:18:22", "negate `rs.level > 0.5`"),
        ("toy_alarm.py:18:35", "`>` → `>=`"),
        ("toy_alarm.py:18:46", "0.5 → 0.55"),
    ]
    assert all(m.code == 'self.state = "ringing" if rs.level > 0.5 else "quiet"' for m in found)


def test_a_dtc_that_visits_the_threshold_kills_every_mutant(toy: Target) -> None:
    spec = record_toy(toy, [0.2, 0.5, 0.52, 0.9, 0.1])

    assert fates(toy, spec) == {
        "negate `rs.level > 0.5`": Outcome.KILLED,
        "`>` → `>=`": Outcome.KILLED,
        "0.5 → 0.55": Outcome.KILLED,
    }


def test_mutants_no_recorded_state_tells_apart_are_possibly_equivalent(toy: Target) -> None:
    spec = record_toy(toy, [0.2, 0.9, 0.1, 0.7])

    assert fates(toy, spec) == {
        "negate `rs.level > 0.5`": Outcome.KILLED,
        "`>` → `>=`": Outcome.POSSIBLY_EQUIVALENT,
        "0.5 → 0.55": Outcome.POSSIBLY_EQUIVALENT,
    }
