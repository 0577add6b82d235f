"""``beatlog demo``: the robot dog live for a short scenario, its replay, then its suite."""

from __future__ import annotations

import dataclasses
import os
import time
from pathlib import Path

from rich.console import Console
from rich.rule import Rule

from beatlog.analysis.summary import summarize
from beatlog.record.recorder import Recorder
from beatlog.replay.judge import replay
from beatlog.report.console import render_replay, render_suite, render_summary
from beatlog.report.counts import verdict_counts
from beatlog.suite.discovery import discover_specs
from beatlog.suite.parallel import run_suite
from beatlog.suite.runner import Verdict
from beatlog_examples.dog import SUITE_DIR
from beatlog_examples.dog.robot import SYSTEM_REF, DogRobot
from beatlog_examples.dog.scenarios import DEMO, describe

__all__ = ["run_demo"]


def run_demo(console: Console, *, duration_s: float, out: Path) -> int:
    """Run the demo; 0 when the session and every DTC of the suite passed."""
    out.mkdir(parents=True, exist_ok=True)
    log = out / "dog.beatlog"
    scenario = dataclasses.replace(DEMO, duration_s=duration_s)
    robot = DogRobot(scenario)

    console.print(Rule("1. record a live session"))
    console.print(
        f"The robot dog runs for {duration_s:g} s in real time in MuJoCo on a 30 ms heartbeat; "
        "physics steps at 500 Hz and each sensor driver publishes from its own thread. "
        "The scripted tester will: "
        + "; ".join(f"at {e.at_s:g} s {describe(e)}" for e in scenario.events)
        + "."
    )
    with (
        Recorder(  # each run of the demo records its session afresh
            log, robot.system, overwrite=True, robot_id="demo-dog", system_ref=SYSTEM_REF
        ) as recorder,
        console.status("recording…"),
    ):
        recorder.run(robot, duration_s=duration_s)
    console.print(render_summary(summarize(log)))

    console.print(Rule("2. replay it as a deterministic test case"))
    passed = replay(log, SYSTEM_REF)
    console.print(render_replay(passed))

    console.print(Rule("3. replay the committed suite"))
    specs = discover_specs([SUITE_DIR])
    console.print(f"{len(specs)} DTCs recorded on the dog, replayed on all cores ({SUITE_DIR}).")
    started = time.perf_counter()
    outcomes = run_suite(specs, jobs=os.cpu_count() or 1)
    wall = time.perf_counter() - started
    console.print(render_suite(outcomes))
    passes = sum(outcome.verdict is Verdict.PASSED for outcome in outcomes)
    cycles = sum(outcome.result.cycles for outcome in outcomes if outcome.result)
    counts = verdict_counts(outcome.verdict for outcome in outcomes)
    console.print(f"{counts} in {wall:.2f} s ({cycles:,} cycles)")
    console.print(f"\nThe demo log is kept at {log}; try `beatlog show {log}`.")
    return 0 if passed.ok and passes == len(outcomes) else 1
