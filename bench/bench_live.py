"""Does recording disturb the live dog? Heartbeats with and without a recorder, alternated.

The live dog (physics at 500 Hz, eight sensor drivers, the remote-control server and
the tester, with remote clients started as in ``bench_dog.py``) runs on its 30 ms
heartbeat in rounds of ``--seconds`` each, three ways in turn: the behaviors stepped
alone and nothing written (*unrecorded*), with a :class:`beatlog.Recorder` (*recorded*),
and with a recorder that also logs the raw sensor samples (*with samples*, as the
committed suite is recorded). Each way's heartbeat intervals from all its rounds are
pooled; the figures are their p50 / p99 / max, and the control thread's CPU a beat
(``time.thread_time``) from the drained samples to the outputs acted on.

Run it as ``python bench/bench_live.py [--seconds 20] [--rounds 3] [--json FILE]``.
Nothing here asserts a timing.
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
from rich.console import Console
from rich.table import Table

from beatlog.model.clock import DEFAULT_PERIOD_NS, LiveHeartbeat
from beatlog.model.context import Outputs
from beatlog.model.cycle import CycleExecutor
from beatlog.model.inbox import Sample
from beatlog.model.random import RecordingRandom
from beatlog.record.recorder import Recorder
from beatlog_examples.dog.robot import SYSTEM_REF, DogRobot
from beatlog_examples.dog.scenarios import Event, Scenario

Step = Callable[[int, msgspec.Struct, Sequence[Sample]], Outputs]
WAYS = ("unrecorded", "recorded", "with samples")


@dataclass
class Beats:
    """What the rounds of one way measured, in ns."""

    intervals: list[int] = field(default_factory=list)
    cpu: list[int] = field(default_factory=list)
    overruns: int = 0
    rounds: list[int] = field(default_factory=list)
    """Where each round's intervals end."""


def scenario(seconds: float) -> Scenario:
    """``bench_dog.py``'s live scenario: drive by remote, a pat, a push, every 30 s."""
    events = tuple(
        event
        for start in range(5, max(6, int(seconds)), 30)
        for event in (
            Event(start, "drive", (0.2, 0.4, 4.0)),
            Event(start + 10, "touch", ("head", 1.0)),
            Event(start + 18, "push", (1,)),
        )
    )
    return Scenario("live", "", seconds, events)


def run_live(dog: DogRobot, step: Step, seconds: float, beats: Beats) -> None:
    """The loop of :meth:`Recorder.run`, keeping each interval and each beat's CPU."""
    clock = LiveHeartbeat(DEFAULT_PERIOD_NS)
    until_ns = int(seconds * 1e9)
    state: msgspec.Struct | None = None
    dog.start()
    try:
        clock.start()
        while clock.now_ns < until_ns:
            interval = clock.wait()
            started = time.thread_time_ns()
            samples = dog.inbox.drain()
            state = dog.perceive(state, samples)
            dog.act(step(interval, state, samples))
            beats.cpu.append(time.thread_time_ns() - started)
            beats.intervals.append(interval)
    finally:
        dog.stop()
    beats.overruns += clock.overruns
    beats.rounds.append(len(beats.intervals))


def unrecorded(seconds: float, beats: Beats) -> None:
    """The dog's behaviors stepped alone: the same cycle, nothing written."""
    dog = DogRobot(scenario(seconds), seed=1)
    random = RecordingRandom(1)
    executor = CycleExecutor(dog.system, random)

    def step(interval_ns: int, state: msgspec.Struct, samples: Sequence[Sample]) -> Outputs:
        executor.step(interval_ns, state)
        random.take()
        return executor.context.outputs

    run_live(dog, step, seconds, beats)


def recorded(seconds: float, beats: Beats, directory: Path, *, log_samples: bool) -> None:
    """The dog with a recorder, writing its log to ``directory``."""
    dog = DogRobot(scenario(seconds), seed=1)
    path = directory / f"live-{len(beats.intervals)}-{log_samples}.beatlog"
    with Recorder(
        path, dog.system, robot_id="dog", system_ref=SYSTEM_REF, seed=1, log_samples=log_samples
    ) as recorder:
        run_live(dog, recorder.step, seconds, beats)
    path.unlink()


def figures(beats: Beats) -> dict[str, Any]:
    """Heartbeat p50 / p99 / max in ms (and each round's p99), CPU a beat p50 / p99 in µs."""
    intervals = np.asarray(beats.intervals, dtype=np.float64) / 1e6
    cpu = np.asarray(beats.cpu, dtype=np.float64) / 1e3
    return {
        "cycles": len(intervals),
        "p50_ms": float(np.percentile(intervals, 50)),
        "p99_ms": float(np.percentile(intervals, 99)),
        "round_p99_ms": [
            float(np.percentile(part, 99)) for part in np.split(intervals, beats.rounds[:-1])
        ],
        "max_ms": float(intervals.max()),
        "cpu_p50_us": float(np.percentile(cpu, 50)),
        "cpu_p99_us": float(np.percentile(cpu, 99)),
        "overruns": beats.overruns,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="robot time a round")
    parser.add_argument("--rounds", type=int, default=3, help="rounds of each way, alternated")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    console = Console(width=132)
    pooled = {way: Beats() for way in WAYS}
    with tempfile.TemporaryDirectory() as tmp:
        for round_ in range(args.rounds):
            for way in WAYS:
                console.print(f"round {round_ + 1}/{args.rounds}: {way}, {args.seconds:g} s ...")
                if way == "unrecorded":
                    unrecorded(args.seconds, pooled[way])
                else:
                    recorded(
                        args.seconds, pooled[way], Path(tmp), log_samples=way == "with samples"
                    )
    results: dict[str, Any] = {way: figures(beats) for way, beats in pooled.items()}
    table = Table(
        title=f"live dog heartbeat, {args.rounds} alternated rounds of {args.seconds:g} s"
    )
    columns = (
        "way",
        "beats",
        "p50 / p99 / max ms",
        "p99 of a round min / median / max ms",
        "CPU a beat p50 / p99 µs",
    )
    for column in (*columns, "overruns"):
        table.add_column(column)
    for way, row in results.items():
        table.add_row(
            way,
            f"{row['cycles']:,}",
            f"{row['p50_ms']:.2f} / {row['p99_ms']:.2f} / {row['max_ms']:.2f}",
            " / ".join(f"{f(row['round_p99_ms']):.2f}" for f in (min, statistics.median, max)),
            f"{row['cpu_p50_us']:.0f} / {row['cpu_p99_us']:.0f}",
            str(row["overruns"]),
        )
    console.print(table)
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
