"""The dog's sensor drivers: what each one reads from the world, and how often.

Each driver turns raw MuJoCo sensor data into the sample a real driver would publish:
rounded to the sensor's resolution, with a little noise, at its own rate.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from beatlog_examples.dog.model import sensor_slice
from beatlog_examples.dog.rates import SENSOR_RATES_HZ
from beatlog_examples.dog.world import CHARGER, DogWorld

__all__ = ["MAX_RANGE", "SENSOR_RATES_HZ", "SensorReader"]

MAX_RANGE = 1.5
"""Range finders report this when they see nothing (MuJoCo's cutoff in ``dog.xml``)."""
RANGES = ("range_left", "range_front", "range_right")
TOUCHES = ("head", "back", "chin", "nose")
JOINTS = ("fl_hip", "fl_knee", "fr_hip", "fr_knee", "hl_hip", "hl_knee", "hr_hip", "hr_knee")


class SensorReader:
    """Reads one driver's sample from the world; call with the world's lock held."""

    def __init__(self, world: DogWorld) -> None:
        self.world = world
        model = world.model
        self._slices = {
            name: sensor_slice(model, name)
            for name in (*RANGES, *TOUCHES, *JOINTS, "accel", "gyro", "velocity")
        }

    def _value(self, name: str) -> float:
        return float(self.world.data.sensordata[self._slices[name]][0])

    def read(self, sensor: str, noise: np.random.Generator) -> Any:
        """The sample the named driver publishes now."""
        data = self.world.data.sensordata
        if sensor == "range":
            return tuple(self._range(self._value(name), noise) for name in RANGES)
        if sensor == "touch":
            return tuple(round(self._value(name), 1) for name in TOUCHES)
        if sensor == "imu":
            ax, ay, az = data[self._slices["accel"]] + noise.normal(0.0, 0.05, 3)
            gyro_z = float(data[self._slices["gyro"]][2]) + float(noise.normal(0.0, 0.01))
            return (round(ax, 2), round(ay, 2), round(az, 2), round(gyro_z, 3))
        if sensor == "odometry":
            return round(self._value("velocity") + float(noise.normal(0.0, 0.005)), 3)
        if sensor == "joints":
            return tuple(round(self._value(name), 2) for name in JOINTS)
        if sensor == "battery":
            battery = self.world.battery
            return (round(battery.level * 100.0, 1), battery.charging)
        if sensor == "beacon":
            return self._beacon(noise)
        world = self.world
        return (world.motion.value, world.speed, world.turn)

    @staticmethod
    def _range(value: float, noise: np.random.Generator) -> float:
        if value < 0.0 or value >= MAX_RANGE:  # nothing within reach
            return MAX_RANGE
        return round(min(MAX_RANGE, max(0.0, value + float(noise.normal(0.0, 0.005)))), 3)

    def _beacon(self, noise: np.random.Generator) -> tuple[float, float]:
        x, y, heading = self.world.pose
        dx, dy = CHARGER[0] - x, CHARGER[1] - y
        bearing = math.remainder(
            math.atan2(dy, dx) - heading + float(noise.normal(0, 0.02)), math.tau
        )
        return (round(bearing, 3), round(math.hypot(dx, dy), 3))
