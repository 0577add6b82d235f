"""The dog's perception step: fold the samples since the last heartbeat into the robot state.

Samples come from the sensor drivers, the remote-control server and the emotion
outputs the robot feeds back. Derived variables (nearest obstacle and its bearing,
tilt, heading) are computed here, once per heartbeat; raw samples are not kept.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from beatlog.model.inbox import Sample
from beatlog.model.perception import Perception
from beatlog_examples.dog.behaviors import DogState
from beatlog_examples.dog.rates import SENSOR_RATES_HZ

__all__ = ["TOUCH_THRESHOLD_N", "perceive", "perception"]

TOUCH_THRESHOLD_N = 1.0
IMU_PERIOD_S = 1.0 / SENSOR_RATES_HZ["imu"]
"""Each IMU sample stands for one driver period of turning, for the heading estimate."""
SPEED_SMOOTHING = 0.05
"""Leg odometry wobbles with every step: the speed is low-passed over about 0.4 s."""
NEAR = 0.8
"""An obstacle closer than this (m) has a bearing."""


def perceive(previous: DogState | None, samples: Sequence[Sample]) -> DogState:
    """The new robot state from the last one and the samples collected since."""
    state = DogState() if previous is None else previous
    fields: dict[str, Any] = {
        name: getattr(state, name)
        for name in (
            "range_left",
            "range_front",
            "range_right",
            "accel_x",
            "accel_y",
            "accel_z",
            "gyro_z",
            "heading",
            "speed",
            "knee_mean",
            "battery",
            "charging",
            "beacon_bearing",
            "beacon_distance",
            "motion",
            "walk_speed",
            "walk_turn",
            "remote_seq",
            "remote_active",
            "remote_speed",
            "remote_turn",
            "happiness",
            "boredom",
        )
    }
    touched: dict[str, Any] = {
        "touch_head": False,
        "touch_back": False,
        "touch_chin": False,
        "bumped": False,
    }
    heading = state.heading
    for sample in samples:
        sensor, value = sample.sensor, sample.value
        if sensor == "imu":
            ax, ay, az, gyro_z = value
            fields.update(accel_x=ax, accel_y=ay, accel_z=az, gyro_z=gyro_z)
            heading += gyro_z * IMU_PERIOD_S
        elif sensor == "range":
            fields.update(range_left=value[0], range_front=value[1], range_right=value[2])
        elif sensor == "touch":
            for name, force in zip(touched, value, strict=True):
                touched[name] = touched[name] or force > TOUCH_THRESHOLD_N
        elif sensor == "odometry":
            fields["speed"] = round(
                fields["speed"] + SPEED_SMOOTHING * (value - fields["speed"]), 3
            )
        elif sensor == "joints":
            # added left to right, not by sum(): Python 3.12 sums floats more exactly,
            # which would round some means the other way than the logs recorded them
            fields["knee_mean"] = round((value[1] + value[3] + value[5] + value[7]) / 4, 2)
        elif sensor == "battery":
            fields.update(battery=value[0], charging=value[1])
        elif sensor == "beacon":
            fields.update(beacon_bearing=value[0], beacon_distance=value[1])
        elif sensor == "motion":
            fields.update(motion=value[0], walk_speed=value[1], walk_turn=value[2])
        elif sensor == "remote":
            speed, turn, active = value
            fields.update(
                remote_seq=fields["remote_seq"] + 1,
                remote_active=active,
                remote_speed=speed,
                remote_turn=turn,
            )
        elif sensor == "emotion":
            fields.update(happiness=value[0], boredom=value[1])
    left, front, right = fields["range_left"], fields["range_front"], fields["range_right"]
    nearest = min(left, front, right)
    ax, ay, az = fields["accel_x"], fields["accel_y"], fields["accel_z"]
    # |az| <= norm in floating point too (sqrt(az * az) == |az|), so acos needs no clamp
    norm = math.sqrt(ax * ax + ay * ay + az * az) or 1.0
    fields["heading"] = round(math.remainder(heading, math.tau), 3)
    return DogState(
        **fields,
        **touched,
        nearest=nearest,
        obstacle_bearing=0 if nearest >= NEAR else (1 if left < right else -1),
        tilt=round(math.degrees(math.acos(az / norm)), 1),
    )


def perception() -> Perception:
    """The perception step for sensor-level replay (a spec's ``perception`` key)."""
    return perceive
