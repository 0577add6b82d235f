"""The live dog: physics in real time in its own thread, a driver thread per sensor.

Physics steps at 500 Hz on a monotonic grid; each sensor driver reads the world at its
own rate and pushes a sample into the inbox; the remote-control server pushes the
commands it receives; a tester thread plays the scenario. At each heartbeat the
recorder folds the samples into the robot state, steps the behaviors and hands their
outputs to :meth:`DogRobot.act`, which drives the motion module.
"""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from beatlog.model.behavior import System
from beatlog.model.context import Outputs
from beatlog.model.inbox import Sample, SensorInbox
from beatlog.record.recorder import Recorder, RecordSummary
from beatlog_examples.dog.behaviors import DogState, system
from beatlog_examples.dog.perception import perceive
from beatlog_examples.dog.rates import SENSOR_RATES_HZ
from beatlog_examples.dog.remote import RemoteServer
from beatlog_examples.dog.scenarios import DEMO, REMOTE_ACTIONS, Event, Scenario, apply
from beatlog_examples.dog.sensors import SensorReader
from beatlog_examples.dog.world import DogWorld

__all__ = [
    "PERCEPTION_REF",
    "REMOTE_PORT",
    "SYSTEM_REF",
    "DogRobot",
    "act_on",
    "record_live",
    "robot",
]

SYSTEM_REF = "beatlog_examples.dog:system"
PERCEPTION_REF = "beatlog_examples.dog.perception:perception"
"""The perception step for sensor-level replay of the dog's recordings."""
REMOTE_PORT = 5555
"""The remote-control port of the robot that ``beatlog record`` builds."""
FREE = Scenario("free", "The dog on its own, for a person to watch and drive.", 60.0)
MAX_CATCH_UP_STEPS = 25
"""Physics steps run back to back at most when the thread fell behind (50 ms)."""
SWITCH_INTERVAL_S = 0.0005
"""While the dog runs, threads hand over the GIL this often (Python's default is 5 ms),
so the heartbeat thread never waits long for it behind the physics and drivers."""


def act_on(world: DogWorld, inbox: SensorInbox, outputs: Outputs, stamp_ns: int) -> None:
    """Apply one cycle's outputs: the motion command, and the emotions fed back as a sample."""
    world.command(
        str(outputs.get("motion", "stand")),
        float(outputs.get("speed", 0.0)),
        float(outputs.get("turn", 0.0)),
    )
    if "happiness" in outputs:
        inbox.push("emotion", (outputs["happiness"], outputs["boredom"]), stamp_ns=stamp_ns)


class DogRobot:
    """The dog in real time; a :class:`beatlog.Robot`.

    :param remote_port: the loopback port of the remote control (0: the OS picks one).
    :param seed: seed of the sensor noise.
    """

    def __init__(
        self,
        scenario: Scenario = DEMO,
        *,
        seed: int | None = None,
        behaviors: System | None = None,
        remote_port: int = 0,
    ) -> None:
        self.scenario = scenario
        self.system: System = behaviors if behaviors is not None else system()
        self.inbox = SensorInbox()
        self.world = scenario.world()
        self.remote = RemoteServer(self.inbox, port=remote_port)
        self._reader = SensorReader(self.world)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._clients: list[subprocess.Popen[bytes]] = []
        self._seed = seed
        self.physics_steps = 0
        self._switch_interval = sys.getswitchinterval()

    def start(self) -> None:
        """Start physics, the sensor drivers, the remote-control server and the tester."""
        self._stop.clear()
        started = time.monotonic()
        seeds = np.random.SeedSequence(self._seed).spawn(len(SENSOR_RATES_HZ))
        threads = [
            threading.Thread(target=self._physics, name="dog-physics", daemon=True),
            threading.Thread(target=self._tester, args=(started,), name="dog-tester", daemon=True),
        ]
        threads += [
            threading.Thread(
                target=self._driver,
                args=(sensor, rate, np.random.default_rng(seed), self.scenario.boot_s(sensor)),
                name=f"dog-{sensor}",
                daemon=True,
            )
            for (sensor, rate), seed in zip(SENSOR_RATES_HZ.items(), seeds, strict=True)
        ]
        self._threads = threads
        self._switch_interval = sys.getswitchinterval()
        sys.setswitchinterval(SWITCH_INTERVAL_S)
        self.remote.start()
        for thread in threads:
            thread.start()

    def stop(self) -> None:
        """Stop everything :meth:`start` started, including remote clients still running."""
        self._stop.set()
        for thread in self._threads:
            thread.join()
        for client in self._clients:
            client.wait()
        self.remote.stop()
        sys.setswitchinterval(self._switch_interval)

    def perceive(self, previous: Any | None, samples: Sequence[Sample]) -> DogState:
        """The perception step (see :func:`beatlog_examples.dog.perception.perceive`)."""
        return perceive(previous, samples)

    def act(self, outputs: Outputs) -> None:
        """Send the winning behavior's motion to the motion module."""
        with self._lock:
            act_on(self.world, self.inbox, outputs, time.monotonic_ns())

    def _physics(self) -> None:
        world, lock = self.world, self._lock
        period = world.timestep
        due = time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic()
            steps = max(1, min(MAX_CATCH_UP_STEPS, int((now - due) / period) + 1))
            with lock:
                for _ in range(steps):
                    world.step()
            self.physics_steps += steps
            due += steps * period
            if now - due > MAX_CATCH_UP_STEPS * period:  # too far behind: drop the backlog
                due = now
            self._stop.wait(max(0.0, due - time.monotonic()))

    def _driver(
        self, sensor: str, rate_hz: float, noise: np.random.Generator, boot_s: float
    ) -> None:
        read = self._reader.read
        if self._stop.wait(boot_s):
            return
        while not self._stop.wait(1.0 / rate_hz):
            with self._lock:
                value = read(sensor, noise)
            self.inbox.push(sensor, value)

    def _tester(self, started: float) -> None:
        for event in self.scenario.events:
            if self._stop.wait(max(0.0, started + event.at_s - time.monotonic())):
                return
            if event.action in REMOTE_ACTIONS:
                self._clients.append(self._remote_client(event))
            else:
                with self._lock:
                    apply(self.world, event)

    def _remote_client(self, event: Event) -> subprocess.Popen[bytes]:
        speed, turn, seconds = event.args
        command = [sys.executable, "-m", "beatlog_examples.dog.remote"]
        command += ["--port", str(self.remote.port), "--for", str(seconds)]
        command += ["forward", str(speed), "turn", str(turn)]
        if event.action == "drive_dropped":
            command.append("--no-release")
        return subprocess.Popen(command)


def robot() -> DogRobot:
    """Factory for ``beatlog record --robot beatlog_examples.dog.robot:robot``: the dog on
    its own in the arena, with its remote control on port :data:`REMOTE_PORT`."""
    return DogRobot(FREE, remote_port=REMOTE_PORT)


def record_live(
    path: str | Path,
    scenario: Scenario,
    *,
    overwrite: bool = False,
    seed: int | None = None,
    log_samples: bool = False,
    on_cycle: Callable[[int], Any] | None = None,
) -> RecordSummary:
    """Record a scenario in real time on the live 30 ms heartbeat; ``overwrite`` replaces
    a log already at ``path`` (recordings are immutable); ``log_samples`` keeps the raw
    sensor samples, for sensor-level replay."""
    dog = DogRobot(scenario, seed=seed)
    with Recorder(
        path,
        dog.system,
        overwrite=overwrite,
        robot_id="dog",
        system_ref=SYSTEM_REF,
        seed=seed,
        log_samples=log_samples,
    ) as recorder:
        return recorder.run(dog, duration_s=scenario.duration_s, on_cycle=on_cycle)
