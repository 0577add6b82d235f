"""The live dog: physics in real time, drivers at their rates, a recorded session replays."""

from __future__ import annotations

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
def test_physics_runs_in_real_time_and_every_driver_publishes_at_its_rate() -> None:
    dog = DogRobot(Scenario("idle", "", 1.0), seed=1)
    dog.start()
    started = time.monotonic()
    time.sleep(1.0)
    samples = dog.inbox.drain()
    dog.stop()
    elapsed = time.monotonic() - started
    assert dog.physics_steps >= 0.8 * 500 * elapsed
    assert dog.world.time_s == pytest.approx(elapsed, rel=0.2)
    counts = Counter(sample.sensor for sample in samples)
    for sensor, rate in SENSOR_RATES_HZ.items():
        assert counts[sensor] >= 0.6 * rate * elapsed - 1, sensor


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
    assert sum(c.heartbeat_ns for c in cycles) / len(cycles) == pytest.approx(30e6, rel=0.2)
    assert dog.remote.rejected == 0
    assert not dog.remote._threads[0].is_alive()


def test_the_factory_builds_a_robot() -> None:
    assert isinstance(robot(), Robot)
