"""What the dog must never do, whatever happens to it: its invariants, checked by beatlog
in every cycle of every DTC of its suite (each spec names them) and, on request, while
it records (``beatlog record --invariants``).

- :func:`never_walks_while_fallen`: once it knows it fell, it gets up before it walks.
- :func:`never_walks_into_an_obstacle`: it never walks forward with something closer
  ahead than its avoid distance, unless a person drives it by remote.
- :class:`DocksWhenLow`: a low battery leads to docking on the charging pad within
  :data:`DOCKING_S` seconds.
- :func:`outputs_within_range`: every command is one its motion module can carry out.
"""

from __future__ import annotations

from beatlog import Cycle
from beatlog_examples.dog.behaviors import Tuning
from beatlog_examples.dog.gait import Motion
from beatlog_examples.dog.remote import MAX_SPEED, MAX_TURN

__all__ = [
    "ALL",
    "DOCKING_S",
    "DocksWhenLow",
    "never_walks_into_an_obstacle",
    "never_walks_while_fallen",
    "outputs_within_range",
]

TUNING = Tuning()
"""The thresholds the behaviors are tuned with: the properties use the same."""
DOCKING_S = 30.0
"""The longest a low battery may go without the dog docked on its pad, in seconds."""
MOTIONS = frozenset(Motion)
ALL = [
    "beatlog_examples.dog.invariants:never_walks_while_fallen",
    "beatlog_examples.dog.invariants:never_walks_into_an_obstacle",
    "beatlog_examples.dog.invariants:DocksWhenLow",
    "beatlog_examples.dog.invariants:outputs_within_range",
]
"""Every invariant of the dog, as a spec names them."""


def _walking(cycle: Cycle) -> bool:
    return cycle.outputs.get("motion") == Motion.WALK


def never_walks_while_fallen(cycle: Cycle) -> None:
    """While getting up after a fall, the dog never walks."""
    if cycle.states["get_up"] == "getting_up":
        assert not _walking(cycle), f"walks while fallen: {dict(cycle.outputs)}"


def never_walks_into_an_obstacle(cycle: Cycle) -> None:
    """The dog never walks forward with an obstacle closer ahead than its avoid
    distance, unless a person drives it by remote."""
    if not _walking(cycle) or cycle.outputs.get("speed", 0.0) <= 0.0:
        return
    if cycle.states["arbiter"] == "remote":
        return
    ahead = cycle.robot_state.range_front
    assert ahead >= TUNING.avoid_distance, (
        f"walks forward at {cycle.outputs['speed']} m/s with an obstacle {ahead} m ahead "
        f"(avoid distance {TUNING.avoid_distance} m), led by {cycle.states['arbiter']}"
    )


class DocksWhenLow:
    """A battery below the low mark leads to docking on the charging pad within
    :data:`DOCKING_S` seconds: it looks across cycles, so each replay has its own."""

    def __init__(self) -> None:
        self.low_since_ns: int | None = None

    def __call__(self, cycle: Cycle) -> None:
        docked = cycle.states["recharge"] in {"docked", "charging"}
        low = cycle.robot_state.battery < TUNING.low_battery
        if docked or not low:
            self.low_since_ns = None
            return
        if self.low_since_ns is None:
            self.low_since_ns = cycle.time_ns
        waited = (cycle.time_ns - self.low_since_ns) / 1e9
        assert waited <= DOCKING_S, (
            f"battery low ({cycle.robot_state.battery:.1f} %) for {waited:.1f} s "
            f"without docking; recharge is {cycle.states['recharge']}"
        )


def outputs_within_range(cycle: Cycle) -> None:
    """Every command is one the motion module carries out: a known motion, a speed
    and turn rate within the actuators' range, emotions from 0 to 100."""
    outputs = cycle.outputs
    motion = outputs.get("motion")
    assert motion is None or motion in MOTIONS, f"no such motion: {motion!r}"
    speed = outputs.get("speed", 0.0)
    assert -MAX_SPEED <= speed <= MAX_SPEED, f"speed {speed} m/s beyond ±{MAX_SPEED}"
    turn = outputs.get("turn", 0.0)
    assert -MAX_TURN <= turn <= MAX_TURN, f"turn rate {turn} rad/s beyond ±{MAX_TURN}"
    for emotion in ("happiness", "boredom"):
        level = outputs.get(emotion, 0)
        assert 0 <= level <= 100, f"{emotion} {level} outside 0-100"
