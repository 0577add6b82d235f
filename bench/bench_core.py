"""Core benchmarks of beatlog on the example rover, measured in one run.

1. Generating a 35,000-cycle log (17.5 minutes at 30 ms) with the lockstep rover.
2. Replay throughput, in cycles/s (CPU time) and × real time.
3. Replay against a bare loop (``bare.py``): the same behaviors fed pre-decoded states
   and random numbers, with no framework around them; CPU time, medians of alternated
   rounds.
4. Reading the log against a plain zstd-compressed msgpack stream of the same cycles.
5. The recorder's cost on the control thread and the heartbeat jitter, live, with and
   without recording.
6. The cycles lost when a recording process is killed with SIGKILL.

Run it as ``python bench/bench_core.py [--json FILE] [--replay-only]``; it takes about
35 s on 2 cores (``--replay-only``: 1 to 3 alone).
Ratios are measured within the run; nothing here asserts a timing.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import msgspec
import numpy as np
import zstandard
from rich.console import Console
from rich.table import Table

import beatlog
from bare import replay_against_bare
from beatlog.log.format import CycleRecord
from beatlog.log.reader import SessionLogReader
from beatlog.model.clock import DEFAULT_PERIOD_NS, LiveHeartbeat
from beatlog.model.context import Outputs
from beatlog.model.cycle import CycleExecutor
from beatlog.model.inbox import Sample
from beatlog.model.random import RecordingRandom
from beatlog.record.recorder import Recorder
from beatlog_examples.rover import RoverRobot, RoverState, record_lockstep, system

DURATION_S = 1050.0
"""Robot time of the generated log: the paper's 17.5 minutes, 35,000 cycles at 30 ms."""
REPEATS = 5
REPLAY_ROUNDS = 11
"""Alternated rounds of replay and the bare loop; the figures are their medians."""
LIVE_S = 10.0
KILL_AFTER_S = 3.5
KILL_RUNS = 3
FLUSH_INTERVAL_S = 1.0
"""The recorder's default flush interval, used by the killed recordings."""
CHILD_MAX_S = 120.0
"""Robot time a killed recording would run for if nobody killed it."""
SYSTEM_REF = "beatlog_examples.rover:system"

Figures = dict[str, Any]
T = TypeVar("T")
A = TypeVar("A")
B = TypeVar("B")


def timed(run: Callable[[], T]) -> tuple[float, T]:
    """Run ``run`` once; its wall time in seconds and its result."""
    started = time.perf_counter()
    result = run()
    return time.perf_counter() - started, result


def interleaved(
    first: Callable[[], A], second: Callable[[], B]
) -> tuple[list[tuple[float, A]], list[tuple[float, B]]]:
    """Time two runs alternately, ``REPEATS`` times each, so both see the same machine."""
    firsts: list[tuple[float, A]] = []
    seconds: list[tuple[float, B]] = []
    for _ in range(REPEATS):
        firsts.append(timed(first))
        seconds.append(timed(second))
    return firsts, seconds


def fastest(runs: list[tuple[float, T]]) -> tuple[float, T]:
    """The run with the least wall time."""
    return min(runs, key=lambda run: run[0])


# 1. Generation -----------------------------------------------------------------------


def bench_generate(path: Path) -> Figures:
    """Record the 35,000-cycle log in lockstep."""
    started = time.perf_counter()
    summary = record_lockstep(path, duration_s=DURATION_S, seed=1)
    seconds = time.perf_counter() - started
    return {
        "cycles": summary.cycles,
        "robot_time_s": summary.robot_time_ns / 1e9,
        "seconds": seconds,
        "cycles_per_s": summary.cycles / seconds,
        "file_bytes": path.stat().st_size,
    }


# 2 and 3. Replay, and replay against a bare loop -------------------------------------


def bench_replay_and_bare(path: Path, rounds: int) -> tuple[Figures, Figures]:
    """Replay and the bare loop (:mod:`bare`), alternately, in CPU time: throughput, and
    the ratio of the medians."""
    figures = replay_against_bare(path, system, rounds)
    replay = {
        key: figures[key] for key in ("replay_ok", "cycles", "replay_cpu_s", "replay_cycles_per_s")
    }
    replay["speedup"] = figures["replay_speedup_best"]
    replay["speedup_median"] = figures["replay_speedup_median"]
    bare = {key: value for key, value in figures.items() if key not in replay}
    return replay, bare


# 4. Log decoding ---------------------------------------------------------------------


def read_log(path: Path) -> int:
    """Iterate the log's batches and decode every cycle's robot state; the cycle count."""
    decode = msgspec.msgpack.Decoder(RoverState).decode
    cycles = 0
    with SessionLogReader(path) as reader:
        for batch in reader.batches():
            for record in batch:
                decode(record.robot_state)
            cycles += len(batch)
    return cycles


def plain_stream(path: Path) -> bytes:
    """The log's cycles as one msgpack array, zstd-compressed at the default level."""
    with SessionLogReader(path) as reader:
        records = list(reader.cycles())
    return zstandard.ZstdCompressor().compress(msgspec.msgpack.encode(records))


def read_plain(blob: bytes) -> int:
    """Decompress and decode the plain stream and every robot state; the cycle count."""
    records = msgspec.msgpack.decode(
        zstandard.ZstdDecompressor().decompress(blob), type=list[CycleRecord]
    )
    decode = msgspec.msgpack.Decoder(RoverState).decode
    for record in records:
        decode(record.robot_state)
    return len(records)


def bench_decode(path: Path) -> Figures:
    """Reading the log against reading a plain zstd msgpack stream, best of five each."""
    blob = plain_stream(path)
    log_runs, plain_runs = interleaved(lambda: read_log(path), lambda: read_plain(blob))
    log_s, log_cycles = fastest(log_runs)
    plain_s, plain_cycles = fastest(plain_runs)
    log_rate = log_cycles / log_s
    plain_rate = plain_cycles / plain_s
    return {
        "cycles": log_cycles,
        "same_cycles": log_cycles == plain_cycles,
        "log_bytes": path.stat().st_size,
        "plain_bytes": len(blob),
        "log_runs_s": [run[0] for run in log_runs],
        "plain_runs_s": [run[0] for run in plain_runs],
        "log_cycles_per_s": log_rate,
        "plain_cycles_per_s": plain_rate,
        "log_over_plain": log_rate / plain_rate,
    }


# 5. Live recording cost and heartbeat jitter -----------------------------------------

Step = Callable[[int, RoverState, list[Sample]], Outputs]


@dataclass
class LiveRun:
    """What one live run measured, in ns."""

    intervals: list[int]
    steps: list[int]
    overruns: int


def run_live(robot: RoverRobot, step: Step, seconds: float) -> LiveRun:
    """The record loop of :meth:`Recorder.run`, timing each step and each heartbeat."""
    clock = LiveHeartbeat(DEFAULT_PERIOD_NS)
    until_ns = int(seconds * 1e9)
    run = LiveRun([], [], 0)
    state: RoverState | None = None
    robot.start()
    try:
        clock.start()
        while clock.now_ns < until_ns:
            run.intervals.append(clock.wait())
            samples = robot.inbox.drain()
            state = robot.perceive(state, samples)
            started = time.perf_counter_ns()
            outputs = step(run.intervals[-1], state, samples)
            run.steps.append(time.perf_counter_ns() - started)
            robot.act(outputs)
    finally:
        robot.stop()
    run.overruns = clock.overruns
    return run


def live_recording(path: Path, seconds: float) -> tuple[LiveRun, list[int]]:
    """Run the live rover with a recorder; the run and the writer's append times."""
    robot = RoverRobot(seed=1)
    appends: list[int] = []
    with Recorder(path, robot.system, system_ref=SYSTEM_REF, seed=1, software="bench") as recorder:
        writer = recorder._writer
        append = writer.append

        def timed_append(
            hb_ns: int,
            state: msgspec.Struct | msgspec.Raw,
            changes: Sequence[Any],
            draws: Sequence[Any],
            outputs: Outputs,
            samples: Sequence[Any] = (),
        ) -> None:
            started = time.perf_counter_ns()
            append(hb_ns, state, changes, draws, outputs, samples)
            appends.append(time.perf_counter_ns() - started)

        writer.append = timed_append  # type: ignore[method-assign]
        run = run_live(robot, recorder.step, seconds)
    return run, appends


def hot_append(path: Path, cycles: int = 10_000) -> list[int]:
    """The writer's append timed back to back, caches warm: its cost without idle gaps."""
    state = RoverState()
    outputs: Outputs = {"speed": 0.35, "turn_rate": 0.0}
    times: list[int] = []
    with Recorder(path, system(), system_ref=SYSTEM_REF, seed=1, software="bench") as recorder:
        append = recorder._writer.append
        for _ in range(cycles):
            started = time.perf_counter_ns()
            append(DEFAULT_PERIOD_NS, state, [], [], outputs)
            times.append(time.perf_counter_ns() - started)
    return times


def live_bare(seconds: float) -> LiveRun:
    """Run the live rover on a cycle executor alone: the same cycle, nothing written."""
    robot = RoverRobot(seed=1)
    random = RecordingRandom(1)
    executor = CycleExecutor(robot.system, random)

    def step(interval_ns: int, state: RoverState, samples: list[Sample]) -> Outputs:
        executor.step(interval_ns, state)
        random.take()
        return executor.context.outputs

    return run_live(robot, step, seconds)


def micros(values_ns: Sequence[int]) -> Figures:
    """p50, p99 and max in µs."""
    array = np.asarray(values_ns, dtype=np.float64) / 1e3
    return {
        "p50_us": float(np.percentile(array, 50)),
        "p99_us": float(np.percentile(array, 99)),
        "max_us": float(array.max()),
    }


def heartbeat(run: LiveRun) -> Figures:
    """Heartbeat interval statistics in ms."""
    array = np.asarray(run.intervals, dtype=np.float64) / 1e6
    period_ms = DEFAULT_PERIOD_NS / 1e6
    return {
        "cycles": len(run.intervals),
        "p50_ms": float(np.percentile(array, 50)),
        "p99_ms": float(np.percentile(array, 99)),
        "max_ms": float(array.max()),
        "max_abs_dev_ms": float(np.abs(array - period_ms).max()),
        "beats_over_32ms": int((array > period_ms + 2.0).sum()),
        "overruns": run.overruns,
    }


def bench_live(directory: Path, seconds: float) -> Figures:
    """Recorder cost and heartbeat jitter, with recording and then without."""
    path = directory / "live.beatlog"
    recorded, appends = live_recording(path, seconds)
    bare = live_bare(seconds)
    replayed = beatlog.replay(path, system())
    return {
        "seconds": seconds,
        "append": micros(appends),
        "append_hot_loop": micros(hot_append(directory / "hot.beatlog")),
        "step_recording": micros(recorded.steps),
        "step_bare": micros(bare.steps),
        "heartbeat_recording": heartbeat(recorded),
        "heartbeat_bare": heartbeat(bare),
        "live_log_replays_ok": replayed.ok and replayed.cycles == len(recorded.steps),
    }


# 6. Cycles lost on SIGKILL -----------------------------------------------------------


def child_record(path: Path) -> None:
    """In the child: record the live rover, printing the cycle count after every step."""
    robot = RoverRobot(seed=1)
    with Recorder(
        path,
        robot.system,
        system_ref=SYSTEM_REF,
        flush_interval_s=FLUSH_INTERVAL_S,
        software="bench",
    ) as recorder:
        recorder.run(robot, duration_s=CHILD_MAX_S, on_cycle=lambda n: print(n, flush=True))


def collect_counts(lines: Iterable[str], counts: list[int], first: threading.Event) -> None:
    """Keep every complete cycle count the child printed."""
    for line in lines:
        if line.endswith("\n"):
            counts.append(int(line))
            first.set()


def kill_run(path: Path) -> Figures:
    """Record in a child for a while after its first cycle, SIGKILL it, read what is left."""
    child = subprocess.Popen(
        [sys.executable, str(Path(__file__).resolve()), "--child-record", str(path)],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert child.stdout is not None
    counts: list[int] = []
    first = threading.Event()
    reader = threading.Thread(target=collect_counts, args=(child.stdout, counts, first))
    reader.start()
    first.wait(timeout=60.0)
    time.sleep(KILL_AFTER_S)
    child.send_signal(signal.SIGKILL)
    child.wait()
    reader.join()
    child.stdout.close()
    with SessionLogReader(path) as log:
        recovered = sum(len(batch) for batch in log.batches())
        status = log.status.describe()
    printed = counts[-1] if counts else 0
    return {
        "printed": printed,
        "recovered": recovered,
        "lost": printed - recovered,
        "status": status,
        "flush_interval_cycles": FLUSH_INTERVAL_S * 1e9 / DEFAULT_PERIOD_NS,
    }


def bench_kill(directory: Path) -> list[Figures]:
    """Three killed recordings."""
    return [kill_run(directory / f"killed-{index}.beatlog") for index in range(KILL_RUNS)]


# Report ------------------------------------------------------------------------------


def machine() -> Figures:
    """What the figures were measured on."""
    return {
        "python": platform.python_version(),
        "implementation": platform.python_implementation(),
        "platform": platform.platform(),
        "cpus": os.cpu_count(),
        "beatlog": beatlog.__version__,
        "msgspec": msgspec.__version__,
    }


def summary(results: Figures) -> list[tuple[str, str, str, bool | None]]:
    """Each headline figure with its target and whether it was met."""
    gen, rep, bare, dec, live = (
        results[key] for key in ("generate", "replay", "bare", "decode", "live")
    )
    app, hot = live["append"], live["append_hot_loop"]
    hb_rec, hb_bare = live["heartbeat_recording"], live["heartbeat_bare"]
    kills = results["kill"]
    worst = max(kill["lost"] for kill in kills)
    flush = kills[0]["flush_interval_cycles"]
    return [
        ("log generation (35k cycles)", f"{gen['seconds']:.2f} s", "—", None),
        ("replay throughput (CPU)", f"{rep['replay_cycles_per_s']:,.0f} cycles/s", "—", None),
        (
            "replay speed, best (median)",
            f"{rep['speedup']:,.0f}× ({rep['speedup_median']:,.0f}×) real time",
            "≥ 1,500×",
            rep["speedup"] >= 1500,
        ),
        (
            "replay / bare loop",
            f"{bare['replay_over_bare']:.2f}",
            "≤ 2.0",
            bare["replay_over_bare"] <= 2.0,
        ),
        (
            "checked loop / bare loop (a pure-Python replay's floor)",
            f"{bare['checked_over_bare']:.2f}",
            "—",
            None,
        ),
        (
            "log read / plain zstd msgpack",
            f"{dec['log_over_plain']:.2f}",
            "≥ 0.5",
            dec["log_over_plain"] >= 0.5,
        ),
        ("recorder append p99 (live)", f"{app['p99_us']:.1f} µs", "≤ 30 µs", app["p99_us"] <= 30),
        (
            "recorder append p50 / p99 (hot loop)",
            f"{hot['p50_us']:.1f} / {hot['p99_us']:.1f} µs",
            "—",
            None,
        ),
        (
            "max |HB − 30 ms|, recording vs not",
            f"{hb_rec['max_abs_dev_ms']:.2f} vs {hb_bare['max_abs_dev_ms']:.2f} ms",
            "—",
            None,
        ),
        (
            "beats > 32 ms, recording vs not",
            f"{hb_rec['beats_over_32ms']} vs {hb_bare['beats_over_32ms']}",
            "no more with recording",
            hb_rec["beats_over_32ms"] <= hb_bare["beats_over_32ms"],
        ),
        (
            "cycles lost on SIGKILL (worst of 3)",
            f"{worst} (flush interval {flush:.1f})",
            "≤ one flush interval",
            worst <= flush,
        ),
    ]


def figures_table(title: str, figures: Figures) -> Table:
    """A two-column table of one benchmark's figures (nested ones flattened)."""
    table = Table(title=title, title_justify="left")
    table.add_column("figure")
    table.add_column("value", justify="right")
    for name, value in flatten(figures):
        table.add_row(name, fmt(value))
    return table


def flatten(figures: Figures, prefix: str = "") -> list[tuple[str, Any]]:
    """Nested figures as (dotted name, value) pairs."""
    rows: list[tuple[str, Any]] = []
    for name, value in figures.items():
        if isinstance(value, dict):
            rows.extend(flatten(value, f"{prefix}{name}."))
        else:
            rows.append((f"{prefix}{name}", value))
    return rows


def fmt(value: Any) -> str:
    """A figure for the console."""
    if isinstance(value, bool) or not isinstance(value, int | float | list):
        return str(value)
    if isinstance(value, list):
        return ", ".join(fmt(item) for item in value)
    if isinstance(value, int):
        return f"{value:,}"
    return f"{value:,.4f}" if abs(value) < 10 else f"{value:,.1f}"


def summary_table(results: Figures) -> Table:
    """The headline figures against their targets."""
    table = Table(title="Summary", title_justify="left")
    for column in ("figure", "measured", "target", "met"):
        table.add_column(column)
    for name, measured, target, met in summary(results):
        table.add_row(name, measured, target, "—" if met is None else ("yes" if met else "NO"))
    return table


def show(console: Console, title: str, figures: Figures) -> Figures:
    """Print one benchmark's figures and hand them back."""
    console.print(figures_table(title, figures))
    return figures


def run_all(console: Console, live_s: float, *, replay_only: bool = False) -> Figures:
    """Every benchmark in order (or 1 to 3 alone), printing each one's figures as it completes."""
    results: Figures = {"machine": show(console, "Machine", machine())}
    with tempfile.TemporaryDirectory(prefix="beatlog-bench-") as tmp:
        directory = Path(tmp)
        log = directory / "rover-35k.beatlog"
        results["generate"] = show(console, "1. Generate the log", bench_generate(log))
        replay, bare = bench_replay_and_bare(log, REPLAY_ROUNDS)
        rounds = f"CPU time, medians of {REPLAY_ROUNDS}"
        results["replay"] = show(console, f"2. Replay throughput ({rounds})", replay)
        results["bare"] = show(console, f"3. Replay / bare loop ({rounds}, alternated)", bare)
        if replay_only:
            return results
        decode = bench_decode(log)
        results["decode"] = show(console, "4. Log read vs plain zstd msgpack (best of 5)", decode)
        live = bench_live(directory, live_s)
        results["live"] = show(console, f"5. Live recording cost ({live_s:g} s each)", live)
        results["kill"] = [
            show(console, f"6. Cycles lost on SIGKILL, run {index}", kill)
            for index, kill in enumerate(bench_kill(directory), start=1)
        ]
    console.print(summary_table(results))
    return results


def main() -> None:
    """Run the benchmarks, or be the recording child of the SIGKILL benchmark."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the figures here")
    parser.add_argument(
        "--live-seconds", type=float, default=LIVE_S, help="length of each live run"
    )
    parser.add_argument(
        "--replay-only", action="store_true", help="only generate the log and time replay"
    )
    parser.add_argument("--child-record", type=Path, metavar="PATH", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child_record is not None:
        child_record(args.child_record)
        return
    results = run_all(Console(), args.live_seconds, replay_only=args.replay_only)
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
