"""Fast-forward recording: the dog's sessions without waiting, for long benchmark logs.

Physics steps in lockstep with heartbeat intervals drawn from the intervals measured
in a live recording, so the log carries real OS jitter; sensors sample at their live
rates in simulated time, remote commands arrive at the client's rate, and the tester
acts at the scenario's times. The same seed and intervals give the same log, byte for
byte.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import System
from beatlog.model.inbox import Sample, SensorInbox
from beatlog.record.recorder import Recorder, RecordSummary
from beatlog_examples.dog.behaviors import DogState, system
from beatlog_examples.dog.perception import perceive
from beatlog_examples.dog.rates import SENSOR_RATES_HZ
from beatlog_examples.dog.remote import RemoteCommand
from beatlog_examples.dog.robot import SYSTEM_REF, act_on
from beatlog_examples.dog.scenarios import REMOTE_ACTIONS, REMOTE_RATE_HZ, Scenario, apply
from beatlog_examples.dog.sensors import SensorReader

__all__ = ["measured_intervals", "record_fast"]

SECOND = 1_000_000_000


def measured_intervals(logs: Sequence[str | Path]) -> list[int]:
    """Every heartbeat interval HB_t recorded in the given (live) logs."""
    intervals: list[int] = []
    for log in logs:
        with SessionLogReader(log) as reader:
            intervals.extend(cycle.heartbeat_ns for cycle in reader.cycles())
    return intervals


def _remote_samples(scenario: Scenario) -> list[tuple[int, tuple[float, float, bool]]]:
    """The remote commands a client would send during the scenario, with their times."""
    timed: list[tuple[int, tuple[float, float, bool]]] = []
    for event in scenario.events:
        if event.action not in REMOTE_ACTIONS:
            continue
        speed, turn, seconds = event.args
        start = int(event.at_s * SECOND)
        count = max(1, round(seconds * REMOTE_RATE_HZ))
        command = RemoteCommand(speed=speed, turn=turn).sample()
        timed += [(start + int(k * SECOND / REMOTE_RATE_HZ), command) for k in range(count)]
        if event.action == "drive":  # "drive_dropped": the link drops, nothing released
            timed.append((start + int(seconds * SECOND), RemoteCommand(release=True).sample()))
    return sorted(timed)


def record_fast(
    path: str | Path,
    scenario: Scenario,
    *,
    intervals: Sequence[int],
    overwrite: bool = False,
    seed: int = 0,
    duration_s: float | None = None,
    behaviors: System | None = None,
    on_cycle: Callable[[int], Any] | None = None,
) -> RecordSummary:
    """Record ``scenario`` (for ``duration_s``, default its own) without waiting.

    :param intervals: measured live heartbeat intervals (ns) to draw HB_t from.
    :param overwrite: replace a log already at ``path`` (recordings are immutable).
    """
    if not intervals:
        raise ValueError("fast-forward needs measured heartbeat intervals to draw from")
    rng = np.random.default_rng(seed)
    jitter = np.asarray(intervals, dtype=np.int64)
    world = scenario.world()
    reader = SensorReader(world)
    inbox = SensorInbox()
    events = sorted(scenario.events, key=lambda event: event.at_s)
    next_event = 0
    remote = _remote_samples(scenario)
    next_remote = 0
    step_ns = int(world.timestep * SECOND)
    due = [
        (int(scenario.boot_s(sensor) * SECOND), sensor, int(SECOND / rate))
        for sensor, rate in SENSOR_RATES_HZ.items()
    ]
    heapq.heapify(due)
    until_ns = int((duration_s if duration_s is not None else scenario.duration_s) * SECOND)
    now_ns = beat_ns = 0
    state: DogState | None = None
    with Recorder(
        path,
        behaviors if behaviors is not None else system(),
        overwrite=overwrite,
        robot_id="dog-fastforward",
        system_ref=SYSTEM_REF,
        seed=seed,
        software="fastforward",
        start_time_ns=0,
    ) as recorder:
        while beat_ns < until_ns:
            interval = int(jitter[rng.integers(len(jitter))])
            beat_ns += interval
            while now_ns < beat_ns:
                while next_event < len(events) and events[next_event].at_s * SECOND <= now_ns:
                    if events[next_event].action not in REMOTE_ACTIONS:
                        apply(world, events[next_event])
                    next_event += 1
                while next_remote < len(remote) and remote[next_remote][0] <= now_ns:
                    inbox.push("remote", remote[next_remote][1], stamp_ns=now_ns)
                    next_remote += 1
                world.step()
                now_ns += step_ns
                while due[0][0] <= now_ns:
                    _at, sensor, period = due[0]
                    inbox.push(sensor, reader.read(sensor, rng), stamp_ns=now_ns)
                    heapq.heapreplace(due, (now_ns + period, sensor, period))
            samples: list[Sample] = inbox.drain()
            state = perceive(state, samples)
            act_on(world, inbox, recorder.step(interval, state, samples), now_ns)
            if on_cycle is not None:
                on_cycle(recorder.cycles)
        return RecordSummary(recorder.cycles, recorder.robot_time_ns, 0, recorder.error)
