"""Benchmarks of the robot dog, measured in one run.

1. Fast-forward: a 17.5-minute dog session (35,000 cycles) recorded in lockstep with
   heartbeat intervals drawn from the committed suite's live recordings.
2. Replay of that session on one core (the process pinned to one CPU), × real time,
   and replay against a bare loop on it (``bare.py``): CPU time, medians of alternated
   rounds.
3. The committed suite replayed on all cores, wall time, as ``beatlog test``
   runs it (worker processes included), and on one worker for comparison.
4. A live recording in real time (physics, drivers, remote server, tester and
   recorder all running): heartbeat intervals p50 / p99 / max from the log.

Run it as ``python bench/bench_dog.py [--live-seconds 60] [--json FILE] [--replay-only]``;
it takes about two minutes on 2 cores (``--replay-only``: 1 and 2 alone). Nothing here
asserts a timing.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from rich.console import Console
from rich.table import Table

import beatlog
from bare import replay_against_bare
from beatlog.log.reader import SessionLogReader
from beatlog.suite.discovery import discover_specs
from beatlog.suite.parallel import run_suite
from beatlog.suite.runner import Verdict
from beatlog_examples.dog import SUITE_DIR, system
from beatlog_examples.dog.fastforward import measured_intervals, record_fast
from beatlog_examples.dog.robot import SYSTEM_REF, record_live
from beatlog_examples.dog.scenarios import Event, Scenario, scenario

LONG_S = 1050.0
"""The paper's 17.5 minutes: 35,000 cycles at 30 ms."""
REPLAYS = 3
REPLAY_ROUNDS = 11
"""Alternated rounds of replay and the bare loop; the figures are their medians."""


def long_scenario() -> Scenario:
    """The arena walk with a tester who pats, pushes and places a box now and then."""
    events = []
    for start in range(20, int(LONG_S), 120):
        events += [
            Event(start, "place_ahead", ("box1", 0.8)),
            Event(start + 30, "touch", ("head", 1.0)),
            Event(start + 60, "push", (1,)),
            Event(start + 90, "touch", ("back", 1.0)),
        ]
    base = scenario("wander-arena")
    return Scenario("long", base.purpose, LONG_S, tuple(events), start=base.start)


def pinned_to_one_core() -> set[int] | None:
    """Pin this process to one CPU; return the previous set to restore."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    previous = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(previous)})
    return previous


def heartbeat_figures(log: Path) -> dict[str, float]:
    with SessionLogReader(log) as reader:
        intervals = np.array([cycle.heartbeat_ns for cycle in reader.cycles()]) / 1e6
        overruns = reader.end.overruns if reader.end else -1
    return {
        "cycles": len(intervals),
        "p50_ms": float(np.percentile(intervals, 50)),
        "p99_ms": float(np.percentile(intervals, 99)),
        "max_ms": float(intervals.max()),
        "over_33_ms": int((intervals > 33.0).sum()),
        "overruns": overruns,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--live-seconds", type=float, default=60.0)
    parser.add_argument("--json", type=Path, help="also write the figures here")
    parser.add_argument(
        "--replay-only", action="store_true", help="only record the long session and replay it"
    )
    args = parser.parse_args()
    console = Console()
    figures: dict[str, Any] = {
        "python": platform.python_version(),
        "beatlog": beatlog.__version__,
        "mujoco": mujoco.__version__,
        "cpus": os.cpu_count(),
    }
    specs = discover_specs([SUITE_DIR])
    jitter = measured_intervals([spec.log for spec in specs])

    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "long.beatlog"
        console.print(f"1. fast-forward: recording {LONG_S:g} s of robot time ...")
        started = time.perf_counter()
        summary = record_fast(log, long_scenario(), intervals=jitter, seed=1)
        figures["fastforward"] = {
            "cycles": summary.cycles,
            "robot_time_s": summary.robot_time_ns / 1e9,
            "wall_s": time.perf_counter() - started,
            "bytes": log.stat().st_size,
            "intervals_drawn_from": len(jitter),
        }

        console.print("2. replaying it on one core ...")
        previous = pinned_to_one_core()
        try:
            results = [beatlog.replay(log, SYSTEM_REF) for _ in range(REPLAYS)]
        finally:
            if previous is not None:
                os.sched_setaffinity(0, previous)
        best = min(results, key=lambda result: result.wall_time_s)
        figures["replay_one_core"] = {
            "ok": all(result.ok for result in results),
            "cycles": best.cycles,
            "best_wall_s": best.wall_time_s,
            "walls_s": [result.wall_time_s for result in results],
            "speedup": best.speedup,
            "median_wall_s": statistics.median(result.wall_time_s for result in results),
            "median_speedup": statistics.median(result.speedup for result in results),
            "us_per_cycle": best.wall_time_s / best.cycles * 1e6,
        }
        console.print("2. replaying it against a bare loop ...")
        figures["replay_over_bare"] = replay_against_bare(log, system, REPLAY_ROUNDS)

    if args.replay_only:
        console.print(figures)
        save(args.json, figures)
        return

    console.print("3. replaying the committed suite ...")
    suite: dict[str, Any] = {"dtcs": len(specs)}
    for jobs in (os.cpu_count() or 1, 1):
        started = time.perf_counter()
        outcomes = run_suite(specs, jobs=jobs)
        suite[f"wall_s_jobs_{jobs}"] = time.perf_counter() - started
        suite[f"passed_jobs_{jobs}"] = sum(o.verdict is Verdict.PASSED for o in outcomes)
    suite["cycles"] = sum(o.result.cycles for o in outcomes if o.result)
    suite["bytes"] = sum(spec.log.stat().st_size for spec in specs)
    figures["suite"] = suite

    console.print(f"4. live recording for {args.live_seconds:g} s ...")
    live = Scenario(
        "live",
        "",
        args.live_seconds,
        tuple(
            event
            for start in range(5, int(args.live_seconds), 30)
            for event in (
                Event(start, "drive", (0.2, 0.4, 4.0)),
                Event(start + 10, "touch", ("head", 1.0)),
                Event(start + 18, "push", (1,)),
            )
        ),
    )
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "live.beatlog"
        record_live(log, live, seed=1)
        figures["live_heartbeat"] = heartbeat_figures(log)
        figures["live_heartbeat"]["replay_ok"] = beatlog.replay(log, SYSTEM_REF).ok

    table = Table(title="robot dog benchmarks")
    for column in ("figure", "measured", "target"):
        table.add_column(column)
    ff, rp, hb = figures["fastforward"], figures["replay_one_core"], figures["live_heartbeat"]
    jobs = os.cpu_count() or 1
    table.add_row(
        "fast-forward 17.5 min session",
        f"{ff['cycles']:,} cycles, {ff['bytes'] / 1e6:.2f} MB in {ff['wall_s']:.1f} s",
        "well under a minute",
    )
    table.add_row(
        f"replay on one core, opening included: best (median) of {REPLAYS}",
        f"{rp['best_wall_s']:.3f} s ({rp['median_wall_s']:.3f} s), {rp['speedup']:,.0f}× "
        f"({rp['median_speedup']:,.0f}×) real time, {rp['us_per_cycle']:.1f} µs/cycle, "
        f"ok={rp['ok']}",
        "≤ 1 s",
    )
    bare = figures["replay_over_bare"]
    table.add_row(
        f"replay / bare loop (CPU, medians of {REPLAY_ROUNDS})",
        f"{bare['replay_over_bare']:.2f} ({bare['replay_us_per_cycle']:.2f} / "
        f"{bare['bare_us_per_cycle']:.2f} µs/cycle), same final states="
        f"{bare['same_final_states']}",
        "≤ 1.5",
    )
    table.add_row(
        "checked loop / bare loop (a pure-Python replay's floor)",
        f"{bare['checked_over_bare']:.2f} ({bare['checked_us_per_cycle']:.2f} µs/cycle)",
        "—",
    )
    table.add_row(
        f"committed suite, {jobs} workers",
        f"{suite[f'wall_s_jobs_{jobs}']:.2f} s ({suite[f'passed_jobs_{jobs}']} passed, "
        f"{suite['cycles']:,} cycles, {suite['bytes'] / 1e6:.2f} MB)",
        "≤ 5 s",
    )
    table.add_row("committed suite, 1 worker", f"{suite['wall_s_jobs_1']:.2f} s", "—")
    table.add_row(
        f"live heartbeat, {hb['cycles']} cycles",
        f"p50 {hb['p50_ms']:.2f} / p99 {hb['p99_ms']:.2f} / max {hb['max_ms']:.2f} ms, "
        f"{hb['over_33_ms']} beats > 33 ms, {hb['overruns']} overruns, "
        f"replay ok={hb['replay_ok']}",
        "p99 ≤ 33 ms",
    )
    console.print(table)
    save(args.json, figures)


def save(path: Path | None, figures: dict[str, Any]) -> None:
    """Write the figures as JSON, when asked to."""
    if path is not None:
        path.write_text(json.dumps(figures, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
