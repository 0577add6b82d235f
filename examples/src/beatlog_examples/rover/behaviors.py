"""The rover's robot state and behaviors, under a priority arbiter.

Highest priority first: escape (bumped: back up, then turn a random way), avoid
(something close ahead: turn away from the nearer side), wander (drive, veering at
random). Time and randomness come only from the context.
"""

from __future__ import annotations

from beatlog.model.behavior import BehaviorState, PriorityArbiter
from beatlog.model.context import Context, Outputs
from beatlog.model.state import RobotState

__all__ = ["Avoid", "Escape", "RoverState", "Wander", "changed_system", "system"]

AVOID_DISTANCE = 0.45
"""Avoid takes over when the front range falls below this (m)."""


class RoverState(RobotState, kw_only=True):
    """The rover's light robot state: latest ranges, bumper, odometry, derived bearing."""

    range_left: float = 3.0
    range_front: float = 3.0
    range_right: float = 3.0
    bumped: bool = False
    x: float = 0.0
    y: float = 0.0
    heading: float = 0.0
    nearest: float = 3.0
    """The smallest of the three ranges (derived)."""
    obstacle_bearing: int = 0
    """-1 when the nearer side obstacle is on the right, +1 on the left, 0 when clear."""


def _drive(speed: float, turn_rate: float) -> Outputs:
    return {"speed": speed, "turn_rate": turn_rate}


class Escape:
    """After a bump: back up for a while, then turn a random way for a random time."""

    name = "escape"

    def __init__(self, back_up_s: float = 0.6) -> None:
        self.state: BehaviorState = "idle"
        self._back_up_ns = int(back_up_s * 1e9)
        self._until_ns = 0
        self._direction = 1.0

    def step(self, rs: RoverState, ctx: Context) -> Outputs | None:
        if rs.bumped and self.state == "idle":
            self.state = "backing"
            self._until_ns = ctx.time_ns + self._back_up_ns
        if self.state == "backing":
            if ctx.time_ns < self._until_ns:
                return _drive(-0.2, 0.0)
            self.state = "turning"
            self._direction = ctx.random.choice((-1.0, 1.0))
            self._until_ns = ctx.time_ns + int(ctx.random.uniform(0.4, 1.2) * 1e9)
        if self.state == "turning":
            if ctx.time_ns < self._until_ns:
                return _drive(0.0, 1.5 * self._direction)
            self.state = "idle"
        return None


class Avoid:
    """Turns away from the nearer side while something is close ahead."""

    name = "avoid"

    def __init__(self, distance: float = AVOID_DISTANCE) -> None:
        self.state: BehaviorState = "clear"
        self._distance = distance

    def step(self, rs: RoverState, ctx: Context) -> Outputs | None:
        if self.state == "clear":
            if rs.range_front >= self._distance and min(rs.range_left, rs.range_right) >= 0.2:
                return None
            self.state = "turning_right" if rs.range_left < rs.range_right else "turning_left"
        elif rs.range_front > self._distance + 0.25 and rs.nearest > 0.2:
            self.state = "clear"
            return None
        return _drive(0.05, -1.2 if self.state == "turning_right" else 1.2)


class Wander:
    """Drives ahead in segments of random length, some of them veering at a random rate."""

    name = "wander"

    def __init__(self, speed: float = 0.35) -> None:
        self.state: BehaviorState = "straight"
        self._speed = speed
        self._turn_rate = 0.0
        self._segment_end_ns = 0

    def step(self, rs: RoverState, ctx: Context) -> Outputs | None:
        if ctx.time_ns >= self._segment_end_ns:
            chance = ctx.random
            veer = chance.random() < 0.4
            self._turn_rate = chance.gauss(0.0, 0.5) if veer else 0.0
            self.state = "veering" if veer else "straight"
            self._segment_end_ns = ctx.time_ns + int(chance.uniform(1.0, 3.0) * 1e9)
        return _drive(self._speed, self._turn_rate)


def system(avoid_distance: float = AVOID_DISTANCE) -> PriorityArbiter[RoverState]:
    """The rover's behavior system: escape > avoid > wander."""
    return PriorityArbiter([Escape(), Avoid(avoid_distance), Wander()], robot_state=RoverState)


def changed_system() -> PriorityArbiter[RoverState]:
    """The same system with avoid reacting 10 cm earlier: a deliberate behavior change."""
    return system(avoid_distance=AVOID_DISTANCE + 0.1)
