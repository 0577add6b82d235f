"""The rover as a robot: physics and sensor drivers around the behavior system.

:class:`RoverRobot` runs live: physics steps in its own thread and each sensor driver
pushes samples into the inbox at its own rate, as a real robot's drivers would.
:func:`record_lockstep` records the same robot without waiting, stepping physics in
lockstep with jittered heartbeat intervals, for long sessions in seconds.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from beatlog.model.behavior import System
from beatlog.model.clock import DEFAULT_PERIOD_NS
from beatlog.model.context import Outputs
from beatlog.model.inbox import Sample, SensorInbox
from beatlog.record.recorder import Recorder, RecordSummary
from beatlog_examples.rover.behaviors import RoverState, system
from beatlog_examples.rover.world import World

__all__ = ["RoverRobot", "perceive", "record_lockstep", "robot"]

SENSOR_RATES_HZ = {"range": 20.0, "bump": 50.0, "odometry": 50.0}
PHYSICS_HZ = 200.0
RANGE_NOISE_M = 0.01


def _read(world: World, sensor: str, noise: np.random.Generator) -> Any:
    if sensor == "range":
        return [max(0.0, r + float(noise.normal(0.0, RANGE_NOISE_M))) for r in world.ranges()]
    if sensor == "bump":
        return world.bumped
    return [world.x, world.y, world.heading]


def perceive(previous: RoverState | None, samples: Sequence[Sample]) -> RoverState:
    """Fold the samples since the last heartbeat into a new robot state."""
    state = RoverState() if previous is None else previous
    ranges = (state.range_left, state.range_front, state.range_right)
    bumped = False
    pose = (state.x, state.y, state.heading)
    for sample in samples:
        if sample.sensor == "range":
            ranges = tuple(sample.value)
        elif sample.sensor == "bump":
            bumped = bumped or bool(sample.value)
        elif sample.sensor == "odometry":
            pose = tuple(sample.value)
    left, front, right = ranges
    side = min(left, right)
    return RoverState(
        range_left=left,
        range_front=front,
        range_right=right,
        bumped=bumped,
        x=pose[0],
        y=pose[1],
        heading=pose[2],
        nearest=min(left, front, right),
        obstacle_bearing=0 if side >= 1.0 else (1 if left < right else -1),
    )


def _apply(world: World, outputs: Outputs) -> None:
    world.command(float(outputs.get("speed", 0.0)), float(outputs.get("turn_rate", 0.0)))


class RoverRobot:
    """The live rover: physics at 200 Hz and one driver thread per sensor."""

    def __init__(self, *, seed: int | None = None, behaviors: System | None = None) -> None:
        self.system: System = behaviors if behaviors is not None else system()
        self.inbox = SensorInbox()
        self.world = World()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._seed = seed

    def start(self) -> None:
        """Start physics and the sensor drivers."""
        self._stop.clear()
        seeds = np.random.SeedSequence(self._seed).spawn(len(SENSOR_RATES_HZ))
        self._threads = [threading.Thread(target=self._physics, name="rover-physics", daemon=True)]
        self._threads += [
            threading.Thread(
                target=self._driver,
                args=(sensor, rate, np.random.default_rng(seed)),
                name=f"rover-{sensor}",
                daemon=True,
            )
            for (sensor, rate), seed in zip(SENSOR_RATES_HZ.items(), seeds, strict=True)
        ]
        for thread in self._threads:
            thread.start()

    def stop(self) -> None:
        """Stop physics and the drivers."""
        self._stop.set()
        for thread in self._threads:
            thread.join()

    def perceive(self, previous: Any | None, samples: Sequence[Sample]) -> RoverState:
        """The perception step (see :func:`perceive`)."""
        return perceive(previous, samples)

    def act(self, outputs: Outputs) -> None:
        """Send the winning behavior's drive command to the wheels."""
        with self._lock:
            _apply(self.world, outputs)

    def _physics(self) -> None:
        period = 1.0 / PHYSICS_HZ
        last = time.monotonic()
        while not self._stop.wait(period):
            now = time.monotonic()
            with self._lock:
                self.world.advance(min(now - last, 5 * period))
            last = now

    def _driver(self, sensor: str, rate_hz: float, noise: np.random.Generator) -> None:
        while not self._stop.wait(1.0 / rate_hz):
            with self._lock:
                value = _read(self.world, sensor, noise)
            self.inbox.push(sensor, value)


def robot() -> RoverRobot:
    """Factory for ``beatlog record --robot beatlog_examples.rover:robot``."""
    return RoverRobot()


LOCKSTEP_FLUSH_S = 60.0
"""Robot time between flushes of a lockstep recording (about 0.1 s of wall time)."""


def record_lockstep(
    path: str | Path,
    *,
    duration_s: float,
    overwrite: bool = False,
    seed: int = 0,
    period_ns: int = DEFAULT_PERIOD_NS,
    behaviors: System | None = None,
    on_cycle: Callable[[int], Any] | None = None,
) -> RecordSummary:
    """Record a rover session without waiting: physics steps in lockstep with heartbeats.

    Heartbeat intervals are the period plus Gaussian jitter (0.2 ms) and an occasional
    late beat, like a loaded OS; sensors sample at their own rates in world time.
    ``overwrite`` replaces a log already at ``path`` (recordings are immutable). The log
    is flushed every :data:`LOCKSTEP_FLUSH_S` of robot time: lockstep runs hundreds of
    times faster than real time, so larger chunks cost nothing in safety and read faster.
    """
    rng = np.random.default_rng(seed)
    world = World()
    chosen = behaviors if behaviors is not None else system()
    substep_ns = int(1e9 / PHYSICS_HZ)
    due = dict.fromkeys(SENSOR_RATES_HZ, 0)
    now_ns = 0
    state: RoverState | None = None
    with Recorder(
        path,
        chosen,
        overwrite=overwrite,
        robot_id="rover-lockstep",
        system_ref="beatlog_examples.rover:system",
        period_ns=period_ns,
        seed=seed,
        software="lockstep",
        start_time_ns=0,
        flush_interval_s=LOCKSTEP_FLUSH_S,
    ) as recorder:
        while now_ns < duration_s * 1e9:
            late = rng.uniform(0, 3e6) if rng.random() < 0.01 else 0.0
            interval = max(1, int(period_ns + rng.normal(0.0, 2e5) + late))
            end_ns = now_ns + interval
            samples: list[Sample] = []
            while now_ns < end_ns:
                step_ns = min(substep_ns, end_ns - now_ns)
                world.advance(step_ns / 1e9)
                now_ns += step_ns
                for sensor, rate in SENSOR_RATES_HZ.items():
                    if now_ns >= due[sensor]:
                        samples.append(Sample(sensor, now_ns, _read(world, sensor, rng)))
                        due[sensor] = now_ns + int(1e9 / rate)
            state = perceive(state, samples)
            _apply(world, recorder.step(interval, state, samples))
            if on_cycle is not None:
                on_cycle(recorder.cycles)
        return RecordSummary(recorder.cycles, recorder.robot_time_ns, 0, recorder.error)
