"""The motion module: inverse kinematics, and a crawl that walks and turns as commanded."""

from __future__ import annotations

import math

import pytest

from beatlog_examples.dog.gait import SEGMENT, Gait, Motion, leg_angles
from beatlog_examples.dog.world import DogWorld


def test_leg_angles_put_the_foot_where_asked() -> None:
    for x, z in [(0.0, -0.12), (0.03, -0.1), (-0.04, -0.13)]:
        _roll, hip, knee = leg_angles(x, 0.0, z)
        knee_x, knee_z = -SEGMENT * math.sin(hip), -SEGMENT * math.cos(hip)
        foot_x = knee_x - SEGMENT * math.sin(hip + knee)
        foot_z = knee_z - SEGMENT * math.cos(hip + knee)
        assert (foot_x, foot_z) == pytest.approx((x, z), abs=1e-9)
    roll, _hip, _knee = leg_angles(0.0, 0.02, -0.12)
    assert roll == pytest.approx(math.atan2(0.02, 0.12))


def test_standing_still_keeps_the_joint_targets_still() -> None:
    gait = Gait()
    first = list(gait.step(0.002, Motion.WALK, 0.0, 0.0))
    assert gait.step(0.002, Motion.WALK, 0.0, 0.0) == pytest.approx(first)


def _walk(world: DogWorld, speed: float, turn: float, seconds: float) -> tuple[float, float]:
    """Distance along the start heading and total heading change after walking."""
    x0, y0, heading0 = world.pose
    world.command("walk", speed, turn)
    turned, previous = 0.0, heading0
    for step in range(int(seconds / world.timestep)):
        world.step()
        if step % 25 == 0:
            heading = world.pose[2]
            turned += math.remainder(heading - previous, math.tau)
            previous = heading
    x, y, _heading = world.pose
    return (x - x0) * math.cos(heading0) + (y - y0) * math.sin(heading0), turned


@pytest.mark.parametrize(("speed", "turn"), [(0.2, 0.0), (-0.1, 0.0)])
def test_the_dog_walks_at_the_commanded_speed(speed: float, turn: float) -> None:
    world = DogWorld(x=2.0, y=2.0)
    ahead, turned = _walk(world, speed, turn, 4.0)
    assert ahead / 4.0 == pytest.approx(speed, rel=0.3)
    assert abs(turned) < 0.3
    assert world.upright > 0.95


@pytest.mark.parametrize("turn", [1.0, -1.0])
def test_the_dog_turns_on_the_spot_at_the_commanded_rate(turn: float) -> None:
    world = DogWorld(x=2.0, y=2.0)
    ahead, turned = _walk(world, 0.0, turn, 3.0)
    assert turned / 3.0 == pytest.approx(turn, rel=0.3)
    assert abs(ahead) < 0.1
    assert world.upright > 0.95
