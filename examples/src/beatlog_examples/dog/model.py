"""The dog's MuJoCo model: ``arena.xml`` (the world) including ``dog.xml`` (the robot)."""

from __future__ import annotations

from pathlib import Path

import mujoco

__all__ = ["ARENA_PATH", "DOG_PATH", "load_model", "sensor_slice"]

ARENA_PATH = Path(__file__).with_name("arena.xml")
DOG_PATH = Path(__file__).with_name("dog.xml")


def load_model() -> mujoco.MjModel:
    """Compile the arena with the dog in it."""
    return mujoco.MjModel.from_xml_path(str(ARENA_PATH))


def sensor_slice(model: mujoco.MjModel, name: str) -> slice:
    """Where a named sensor's values lie in ``MjData.sensordata``."""
    sensor = model.sensor(name)
    start = int(sensor.adr[0])
    return slice(start, start + int(sensor.dim[0]))
