"""The live dog: physics in real time, drivers at their rates, a recorded session replays."""

from __future__ import annotations

import socket
import threading
import time
from collections import Counter
from pathlib import Path

import pytest

from beatlog import replay
from beatlog.log.reader import SessionLogReader
from beatlog.model.robot import Robot
from beatlog.record.recorder import Recorder
from beatlog_examples.dog.rates import SENSOR_RATES_HZ
from beatlog_examples.dog.robot import SYSTEM_REF, DogRobot, robot
from beatlog_examples.dog.scenarios import Event, Scenario


@pytest.mark.slow
def test_physics_keeps_to_real_time_and_every_driver_publishes_no_faster_than_its_rate() -> None:
    dog = DogRobot(Scenario("idle", "", 1.0), seed=1)
    started = time.monotonic()
    dog.start()
    time.sleep(1.0)
    samples = dog.inbox.drain()
    dog.stop()
    elapsed = time.monotonic() - started
    assert dog.physics_steps > 0
    assert 0 < dog.world.time_s <= elapsed + dog.world.timestep  # never ahead of the wall clock
    counts = Counter(sample.sensor for sample in samples)
    assert set(counts) == set(SENSOR_RATES_HZ)
    for sensor, rate in SENSOR_RATES_HZ.items():
        assert counts[sensor] <= rate * elapsed, sensor


@pytest.mark.slow
def test_a_driver_still_booting_publishes_nothing_and_stopping_does_not_wait_for_it() -> None:
    dog = DogRobot(Scenario("booting", "", 1.0, booting=(("imu", 3600.0),)), seed=1)
    dog.start()
    time.sleep(0.3)
    dog.stop()
    counts = Counter(sample.sensor for sample in dog.inbox.drain())
    assert counts["imu"] == 0
    assert counts["touch"] > 0
    assert not [thread for thread in threading.enumerate() if thread.name == "dog-imu"]


@pytest.mark.slow
def test_a_live_session_with_a_remote_client_records_and_replays(tmp_path: Path) -> None:
    log = tmp_path / "live.beatlog"
    script = Scenario(
        "short", "", 2.5, (Event(0.2, "drive", (0.2, 0.5, 1.5)), Event(0.5, "touch", ("back", 0.3)))
    )
    dog = DogRobot(script, seed=2)
    with Recorder(log, dog.system, system_ref=SYSTEM_REF, software="t") as recorder:
        summary = recorder.run(dog, duration_s=script.duration_s)
    assert summary.error is None
    assert replay(log, SYSTEM_REF).ok
    with SessionLogReader(log) as reader:
        cycles = list(reader.cycles())
    assert len(cycles) == summary.cycles > 0
    assert sum(c.heartbeat_ns for c in cycles) >= len(cycles) * recorder.period_ns  # paced
    assert dog.remote.rejected == 0
    assert not [thread for thread in threading.enumerate() if thread.name.startswith("dog-")]
    with pytest.raises(ConnectionRefusedError):
        socket.create_connection(("127.0.0.1", dog.remote.port), timeout=5.0)


def test_the_factory_builds_a_robot() -> None:
    assert isinstance(robot(), Robot)
