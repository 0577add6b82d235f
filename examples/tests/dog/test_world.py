"""The MuJoCo world: sensors see walls and touches, the battery drains and charges, the
dog falls when pushed and gets up."""

from __future__ import annotations

import math

import numpy as np
import pytest

from beatlog_examples.dog.gait import Motion
from beatlog_examples.dog.sensors import MAX_RANGE, SensorReader
from beatlog_examples.dog.world import CHARGER, Battery, DogWorld


def run(world: DogWorld, seconds: float) -> None:
    for _ in range(int(seconds / world.timestep)):
        world.step()


@pytest.fixture
def noise() -> np.random.Generator:
    return np.random.default_rng(0)


def test_the_front_range_finder_sees_the_wall_ahead(noise: np.random.Generator) -> None:
    world = DogWorld(x=3.0, y=2.0, heading=0.0)  # the east wall's face is at x = 4
    run(world, 0.2)
    reader = SensorReader(world)
    left, front, right = reader.read("range", noise)
    nose_x = world.pose[0] + 0.175 + 0.046
    assert front == pytest.approx(4.0 - nose_x, abs=0.03)
    world_away = DogWorld(x=2.0, y=2.0, heading=math.pi / 2 + 0.3)
    run(world_away, 0.2)
    assert SensorReader(world_away).read("range", noise)[1] == MAX_RANGE
    assert left > front
    assert right > front


@pytest.mark.parametrize(("part", "index"), [("head", 0), ("back", 1), ("chin", 2)])
def test_a_touch_registers_on_its_sensor_only(
    part: str, index: int, noise: np.random.Generator
) -> None:
    world = DogWorld()
    run(world, 0.3)
    reader = SensorReader(world)
    assert reader.read("touch", noise) == (0.0, 0.0, 0.0, 0.0)
    world.touch(part, 0.2)
    run(world, 0.1)
    forces = reader.read("touch", noise)
    assert forces[index] > 1.0
    assert all(force == 0.0 for i, force in enumerate(forces) if i != index)
    run(world, 0.2)
    assert reader.read("touch", noise)[index] == 0.0


def test_a_lighter_touch_reads_a_smaller_force(noise: np.random.Generator) -> None:
    forces = []
    for press in (0.002, 0.0001):
        world = DogWorld()
        world.command("lie")
        run(world, 1.5)
        world.touch("back", 0.5, press)
        run(world, 0.3)
        forces.append(SensorReader(world).read("touch", noise)[1])
    assert forces[0] > 10.0
    assert 0.5 < forces[1] < 2.5


def test_a_box_placed_against_the_nose_presses_the_nose_sensor(
    noise: np.random.Generator,
) -> None:
    world = DogWorld(x=1.0, y=2.0)
    run(world, 0.3)
    world.place("box1", world.pose[0] + 0.36, world.pose[1])  # 1 cm into the nose
    run(world, 0.05)
    assert SensorReader(world).read("touch", noise)[3] > 1.0


def test_the_battery_drains_faster_walking_and_charges_on_the_pad() -> None:
    idle, walking = Battery(level=0.5), Battery(level=0.5)
    idle.update(10.0, walking=False, docked=False)
    walking.update(10.0, walking=True, docked=False)
    assert walking.level < idle.level < 0.5
    walking.update(10.0, walking=False, docked=True)
    assert walking.charging
    assert walking.level > 0.5


def test_a_drained_battery_reads_low_and_lying_on_the_pad_charges_it(
    noise: np.random.Generator,
) -> None:
    world = DogWorld(x=CHARGER[0], y=CHARGER[1], battery=0.3)
    world.drain(0.01)
    run(world, 1.0)
    level, charging = SensorReader(world).read("battery", noise)
    assert level < 29.5
    assert not charging
    world.command("lie")
    run(world, 1.0)
    assert world.docked
    assert SensorReader(world).read("battery", noise)[1]


def test_pushed_over_the_accelerometer_says_so_and_the_get_up_motion_rights_it(
    noise: np.random.Generator,
) -> None:
    world = DogWorld()
    run(world, 0.3)
    world.push(1)
    run(world, 1.5)
    assert world.upright < 0.5
    _ax, _ay, az, _gyro = SensorReader(world).read("imu", noise)
    assert az < 5.0
    world.command("getup")
    run(world, 2.0)
    world.command("stand")
    run(world, 1.0)
    assert world.upright > 0.95
    assert SensorReader(world).read("imu", noise)[2] > 9.0


def tilt(world: DogWorld, noise: np.random.Generator) -> float:
    ax, ay, az, _gyro = SensorReader(world).read("imu", noise)
    return math.degrees(math.acos(az / math.sqrt(ax * ax + ay * ay + az * az)))


def test_tipped_by_hand_the_dog_tilts_about_as_far_then_stands_again(
    noise: np.random.Generator,
) -> None:
    world = DogWorld()
    run(world, 0.3)
    world.lean(1, 60.0, 3.0)
    run(world, 2.0)
    assert 55.0 < tilt(world, noise) < 70.0
    assert SensorReader(world).read("imu", noise)[1] < -5.0, "it leans to its left"
    run(world, 2.0)
    assert world.upright > 0.95


def test_held_back_by_its_harness_the_dog_walks_on_slowly() -> None:
    free, held = DogWorld(), DogWorld()
    for world in (free, held):
        world.command("walk", 0.18)
        run(world, 0.5)
    held.drag(3.0, 450.0)
    run(free, 3.0)
    run(held, 3.0)
    assert free.pose[0] - 1.0 > 0.35
    assert 0.01 < held.pose[0] - 1.0 < 0.2


def test_an_unknown_motion_stands_still() -> None:
    world = DogWorld()
    world.command("dance", 1.0, 1.0)
    assert world.motion is Motion.STAND


def test_a_load_slows_charging_on_the_pad_and_a_swapped_battery_reads_its_charge() -> None:
    plain, loaded = Battery(level=0.5), Battery(level=0.5, extra_drain=0.015)
    plain.update(10.0, walking=False, docked=True)
    loaded.update(10.0, walking=False, docked=True)
    assert plain.level == pytest.approx(0.5 + 10.0 * plain.charge_rate)
    assert loaded.level == pytest.approx(0.5 + 10.0 * (loaded.charge_rate - 0.015))
    world = DogWorld()
    world.swap_battery(0.895)
    assert SensorReader(world).read("battery", np.random.default_rng(0))[0] == 89.5


@pytest.mark.parametrize(("finder", "index"), [("left", 0), ("front", 1), ("right", 2)])
def test_a_box_placed_at_a_range_reads_that_range_on_its_finder(finder: str, index: int) -> None:
    world = DogWorld(x=CHARGER[0], y=CHARGER[1])
    run(world, 0.2)
    world.place_at_range("box1", finder, 0.508)
    quiet = np.random.default_rng(0)
    readings = [SensorReader(world).read("range", quiet)[index] for _ in range(200)]
    assert sum(readings) / len(readings) == pytest.approx(0.508, abs=0.001)
