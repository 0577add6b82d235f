"""The dog's invariants: each holds on what its behaviors do and fails on what they must
never do; a bug planted in the behaviors fails a DTC with the invariant's panel."""

from __future__ import annotations

from pathlib import Path
from types import MappingProxyType
from typing import Any

import pytest

from beatlog import Cycle, DivergenceKind
from beatlog.record.recorder import Recorder
from beatlog.report.console import plain_text, render_outcome
from beatlog.suite.runner import Verdict, run_spec
from beatlog.suite.spec import load_spec, spec_text
from beatlog_examples.dog.behaviors import DogState, system
from beatlog_examples.dog.invariants import (
    ALL,
    DOCKING_S,
    DocksWhenLow,
    never_walks_into_an_obstacle,
    never_walks_while_fallen,
    outputs_within_range,
)

PERIOD_NS = 30_000_000
STATES = {
    "arbiter": "wander",
    "get_up": "upright",
    "recharge": "ok",
}


def cycle(
    number: int = 0,
    *,
    outputs: dict[str, Any] | None = None,
    states: dict[str, Any] | None = None,
    **fields: Any,
) -> Cycle:
    """A cycle of the dog walking ahead, with what a test changes."""
    return Cycle(
        cycle=number,
        time_ns=(number + 1) * PERIOD_NS,
        dt_ns=PERIOD_NS,
        robot_state=DogState(**fields),
        states=MappingProxyType({**STATES, **(states or {})}),
        changes=(),
        outputs=MappingProxyType({"motion": "walk", "speed": 0.18, "turn": 0.0, **(outputs or {})}),
        draws=(),
    )


def test_walking_ahead_in_the_open_holds_every_invariant() -> None:
    open_ahead = cycle(range_front=1.5)

    for invariant in (never_walks_while_fallen, never_walks_into_an_obstacle, DocksWhenLow()):
        invariant(open_ahead)
    outputs_within_range(open_ahead)


def test_walking_while_getting_up_does_not_hold() -> None:
    with pytest.raises(AssertionError, match="walks while fallen"):
        never_walks_while_fallen(cycle(states={"get_up": "getting_up"}))
    never_walks_while_fallen(cycle(states={"get_up": "getting_up"}, outputs={"motion": "getup"}))


def test_walking_forward_at_an_obstacle_holds_only_when_a_person_drives() -> None:
    with pytest.raises(AssertionError, match=r"obstacle 0.2 m ahead \(avoid distance 0.35 m\)"):
        never_walks_into_an_obstacle(cycle(range_front=0.2))
    never_walks_into_an_obstacle(cycle(states={"arbiter": "remote"}, range_front=0.2))
    never_walks_into_an_obstacle(cycle(outputs={"speed": -0.12}, range_front=0.2))  # backing


def test_a_low_battery_must_lead_to_docking_in_time() -> None:
    docks = DocksWhenLow()
    late = round(DOCKING_S * 1e9 / PERIOD_NS) + 1

    docks(cycle(0, battery=15.0))
    docks(cycle(late - 1, battery=15.0))
    with pytest.raises(AssertionError, match="without docking; recharge is ok"):
        docks(cycle(late, battery=15.0))
    docks(cycle(late + 1, battery=15.0, states={"recharge": "docked"}))
    docks(cycle(2 * late, battery=15.0))  # low again: the clock starts anew


@pytest.mark.parametrize(
    ("outputs", "problem"),
    [
        ({"motion": "fly"}, "no such motion: 'fly'"),
        ({"speed": 0.5}, "speed 0.5 m/s beyond"),
        ({"turn": -2.0}, "turn rate -2.0 rad/s beyond"),
        ({"boredom": 101}, "boredom 101 outside 0-100"),
    ],
)
def test_a_command_beyond_the_actuators_does_not_hold(
    outputs: dict[str, Any], problem: str
) -> None:
    with pytest.raises(AssertionError, match=problem):
        outputs_within_range(cycle(outputs=outputs))


PLANTED = """
from beatlog.model.behavior import PriorityArbiter
from beatlog_examples.dog.behaviors import BEHAVIORS, DogState, GetUp, Tuning


class HastyGetUp(GetUp):
    def step(self, rs, ctx):
        outputs = super().step(rs, ctx)
        if self.state == "getting_up":
            return {"motion": "walk", "speed": 0.1, "turn": 0.0}  # the planted bug
        return outputs


def system():
    tuning = Tuning()
    rest = [kind(tuning) for kind in BEHAVIORS[1:]]
    return PriorityArbiter([HastyGetUp(tuning), *rest], robot_state=DogState)
"""
"""The dog's system with a bug planted in get_up: it walks while getting up."""


def test_a_bug_planted_in_get_up_fails_a_dtc_with_the_invariant_panel(tmp_path: Path) -> None:
    log = tmp_path / "fall.beatlog"
    falls = [DogState(tilt=80.0)] * 30 + [DogState(tilt=5.0)] * 30  # over, then righted
    with Recorder(log, system(), software="test", seed=3) as recorder:
        for state in falls:
            recorder.step(PERIOD_NS, state)
    (tmp_path / "planted.py").write_text(PLANTED, encoding="utf-8")
    spec = tmp_path / "fall.dtc.toml"
    spec.write_text(
        spec_text(
            name="fall",
            purpose="The dog falls over and gets up.",
            procedure=["Tip it over for 0.9 s."],
            log=log.name,
            system="planted:system",
            invariants=ALL,
        ),
        encoding="utf-8",
    )

    outcome = run_spec(load_spec(spec))

    assert outcome.verdict is Verdict.FAILED
    assert outcome.result is not None
    divergence = outcome.result.divergence
    assert divergence is not None
    assert (divergence.kind, divergence.invariant) == (
        DivergenceKind.INVARIANT,
        "never_walks_while_fallen",
    )
    assert divergence.states["get_up"] == "getting_up"
    panel = plain_text(render_outcome(outcome), width=200)
    assert "invariant never_walks_while_fallen does not hold: walks while fallen" in panel
    assert "behavior states after the update" in panel
    assert f"reproduce: beatlog test {spec}" in panel
