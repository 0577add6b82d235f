"""The perception step folds samples into the robot state and derives its variables."""

from __future__ import annotations

import math

import pytest

from beatlog.model.inbox import Sample
from beatlog_examples.dog.behaviors import DogState
from beatlog_examples.dog.perception import perceive


def sample(sensor: str, value: object) -> Sample:
    return Sample(sensor, 0, value)


def test_the_latest_readings_win_and_nothing_new_keeps_the_last_state() -> None:
    state = perceive(
        None,
        [
            sample("range", (1.0, 1.2, 1.5)),
            sample("range", (0.5, 0.6, 1.5)),
            sample("battery", (80.0, False)),
            sample("beacon", (0.3, 2.0)),
            sample("motion", ("walk", 0.18, 0.0)),
            sample("joints", (0.7, -2.2, 0.7, -2.2, 0.7, -2.0, 0.7, -2.0)),
        ],
    )
    assert (state.range_left, state.range_front, state.range_right) == (0.5, 0.6, 1.5)
    assert state.nearest == 0.5
    assert state.obstacle_bearing == 1
    assert (state.battery, state.beacon_bearing, state.motion) == (80.0, 0.3, "walk")
    assert state.knee_mean == -2.1
    assert perceive(state, []) == state


def test_a_touch_anywhere_between_heartbeats_counts() -> None:
    state = perceive(
        None,
        [sample("touch", (0.0, 0.0, 3.0, 0.0)), sample("touch", (0.0, 0.0, 0.0, 0.0))],
    )
    assert state == DogState(touch_chin=True)
    assert perceive(state, []) == DogState()


def test_tilt_comes_from_the_accelerometer_and_heading_from_the_gyro() -> None:
    upright = perceive(None, [sample("imu", (0.0, 0.0, 9.81, 0.0))])
    on_its_side = perceive(None, [sample("imu", (0.0, 9.81, 0.0, 0.0))])
    assert upright.tilt == 0.0
    assert on_its_side.tilt == 90.0
    upside_down = perceive(None, [sample("imu", (0.0, 0.0, -9.81, 0.0))])
    falling = perceive(None, [sample("imu", (0.0, 0.0, 0.0, 0.0))])
    assert (upside_down.tilt, falling.tilt) == (180.0, 90.0)
    turning = perceive(None, [sample("imu", (0.0, 0.0, 9.81, 1.0))] * 100)
    assert turning.heading == pytest.approx(1.0)
    assert perceive(turning, [sample("imu", (0.0, 0.0, 9.81, 1.0))] * 300).heading == (
        pytest.approx(math.remainder(4.0, math.tau), abs=1e-3)
    )


def test_odometry_is_low_passed_so_one_wobble_is_not_a_stop() -> None:
    walking = DogState(speed=0.18)
    assert perceive(walking, [sample("odometry", 0.0)]).speed > 0.15


def test_remote_commands_count_up_and_emotions_come_back() -> None:
    state = perceive(None, [sample("remote", (0.2, 0.5, True))] * 3)
    assert (state.remote_seq, state.remote_active, state.remote_speed) == (3, True, 0.2)
    state = perceive(state, [sample("remote", (0.0, 0.0, False)), sample("emotion", (70, 12))])
    assert (state.remote_seq, state.remote_active) == (4, False)
    assert (state.happiness, state.boredom) == (70, 12)
