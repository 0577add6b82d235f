"""What an invariant is given: one cycle, read-only, its times in ns and in seconds."""

from __future__ import annotations

from types import MappingProxyType

import pytest

import beatlog
from beatlog.model.cycle import RandomDraw, StateChange
from beatlog.model.invariant import Cycle


def a_cycle() -> Cycle:
    return Cycle(
        cycle=3,
        time_ns=120_000_000,
        dt_ns=30_000_000,
        robot_state={"distance": 0.4},
        states=MappingProxyType({"near": "near"}),
        changes=(StateChange("near", "far", "near"),),
        outputs=MappingProxyType({"speed": 0.0}),
        draws=(RandomDraw("dice", "randint", 4, "randint(1, 6)"),),
    )


def test_a_cycle_tells_its_times_in_seconds() -> None:
    cycle = a_cycle()

    assert (cycle.time, cycle.dt) == (0.12, 0.03)


def test_a_cycle_cannot_be_changed_by_an_invariant() -> None:
    cycle = a_cycle()

    with pytest.raises(AttributeError):
        cycle.cycle = 4  # type: ignore[misc]
    with pytest.raises(TypeError):
        cycle.outputs["speed"] = 1.0  # type: ignore[index]
    assert not hasattr(cycle, "__dict__")


def test_cycle_and_invariant_are_beatlog_s_own_names() -> None:
    assert beatlog.Cycle is Cycle
    assert "Invariant" in beatlog.__all__
