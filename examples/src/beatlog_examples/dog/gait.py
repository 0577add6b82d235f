"""The dog's motion module: an open-loop crawl gait and whole-body poses as joint targets.

Each leg's foot follows a target in its hip frame, turned into hip-roll, hip-pitch and
knee angles by two-link inverse kinematics. Walking is a statically stable crawl (one
leg in the air at a time, legs in the order left hind, left front, right hind, right
front); a foot in stance moves against the body velocity it should produce at that
leg, so forward speed and turn rate mix per leg. This is robot firmware, not the
behaviors under test: it runs in the physics loop and is never replayed.
"""

from __future__ import annotations

import math
from enum import StrEnum

__all__ = ["LEGS", "Gait", "Motion", "leg_angles"]

SEGMENT = 0.08
"""Thigh and shin length (m), as in ``dog.xml``."""
STANCE_HEIGHT = 0.12
STEP_HZ = 2.0
SWING = 0.25
"""Fraction of a step cycle a foot spends in the air."""
LIFT = 0.03
SPEED_SCALE = 1.0
"""Commanded speed (m/s) to foot-travel speed, calibrated so the dog walks at the command."""
TURN_SCALE = 0.95
"""Likewise for the turn rate (rad/s)."""
WALK_SMOOTHING_S = 0.03
POSE_SMOOTHING_S = 0.2
"""Time constants of the low-pass filter on the joint targets, walking and changing pose."""

LEGS = (
    # name, hip x, hip y (torso frame), phase offset in the step cycle
    ("fl", 0.11, 0.085, 0.0),
    ("fr", 0.11, -0.085, 0.5),
    ("hl", -0.11, 0.085, 0.75),
    ("hr", -0.11, -0.085, 0.25),
)


class Motion(StrEnum):
    """What the motion module is doing; behaviors ask for one with the ``motion`` output."""

    STAND = "stand"
    """Stand still on four legs."""
    WALK = "walk"
    """Walk with the commanded speed and turn rate."""
    SIT = "sit"
    """Hind legs folded, front legs straight."""
    LIE = "lie"
    """Belly on the ground, legs stretched fore and aft."""
    GETUP = "getup"
    """Legs tucked while the body rights itself."""


def leg_angles(x: float, y: float, z: float) -> tuple[float, float, float]:
    """Hip roll, hip pitch and knee angles that put the foot at (x, y, z) from the hip."""
    roll = math.atan2(y, -z)
    height = math.hypot(y, z)
    reach = min(math.hypot(x, height), 2 * SEGMENT * 0.999)
    knee = -math.acos((reach * reach - 2 * SEGMENT * SEGMENT) / (2 * SEGMENT * SEGMENT))
    pitch = math.atan2(-x, height) + math.acos(reach / (2 * SEGMENT))
    return roll, pitch, knee


def _pose(front: tuple[float, float], hind: tuple[float, float]) -> list[float]:
    angles: list[float] = []
    for name, _x, _y, _phase in LEGS:
        x, z = front if name[0] == "f" else hind
        angles.extend(leg_angles(x, 0.0, z))
    return angles


POSES = {
    Motion.STAND: _pose((0.0, -STANCE_HEIGHT), (0.0, -STANCE_HEIGHT)),
    Motion.SIT: _pose((0.0, -STANCE_HEIGHT), (0.03, -0.05)),
    Motion.LIE: _pose((0.07, -0.015), (-0.07, -0.015)),
    Motion.GETUP: _pose((0.0, -0.07), (0.0, -0.07)),
}


class Gait:
    """Joint targets for the 12 position actuators, one call per physics step."""

    def __init__(self) -> None:
        self.phase = 0.0
        self.targets = list(POSES[Motion.STAND])

    def step(self, dt: float, motion: Motion, speed: float, turn: float) -> list[float]:
        """Advance the gait by ``dt`` seconds and return the filtered joint targets."""
        if motion is Motion.WALK and (speed or turn):
            self.phase = (self.phase + STEP_HZ * dt) % 1.0
            wanted = self._walk(speed * SPEED_SCALE, turn * TURN_SCALE)
            alpha = dt / (WALK_SMOOTHING_S + dt)
        else:
            wanted = POSES[Motion.STAND if motion is Motion.WALK else motion]
            alpha = dt / (POSE_SMOOTHING_S + dt)
        targets = self.targets
        for index, angle in enumerate(wanted):
            targets[index] += (angle - targets[index]) * alpha
        return targets

    def _walk(self, speed: float, turn: float) -> list[float]:
        travel = (1.0 - SWING) / STEP_HZ
        angles: list[float] = []
        for _name, hip_x, hip_y, offset in LEGS:
            dx = (speed - turn * hip_y) * travel
            dy = turn * hip_x * travel
            p = (self.phase + offset) % 1.0
            if p < SWING:
                u = p / SWING
                k = -0.5 * math.cos(math.pi * u)
                z = -STANCE_HEIGHT + LIFT * math.sin(math.pi * u)
            else:
                k = 0.5 - (p - SWING) / (1.0 - SWING)
                z = -STANCE_HEIGHT
            angles.extend(leg_angles(k * dx, k * dy, z))
        return angles
