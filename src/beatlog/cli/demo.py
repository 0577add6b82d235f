"""``beatlog demo``: record the example rover live, replay it, then break a behavior."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console
from rich.rule import Rule

from beatlog.engine.record import Recorder
from beatlog.engine.replay import replay
from beatlog.examples.rover import RoverRobot
from beatlog.log.summary import summarize
from beatlog.report.console import render_replay, render_summary

__all__ = ["run_demo"]

SYSTEM = "beatlog.examples.rover:system"
CHANGED_SYSTEM = "beatlog.examples.rover:changed_system"


def run_demo(console: Console, *, duration_s: float, out: Path) -> int:
    """Run the demo; 0 when it showed what it set out to show."""
    out.mkdir(parents=True, exist_ok=True)
    log = out / "rover.beatlog"
    robot = RoverRobot()

    console.print(Rule("1. record a live session"))
    console.print(
        f"The rover drives for {duration_s:g} s in real time on a 30 ms heartbeat; its range, "
        "bump and odometry drivers run in their own threads."
    )
    with (
        Recorder(log, robot.system, robot_id="demo-rover", system_ref=SYSTEM) as recorder,
        console.status("recording…"),
    ):
        recorder.run(robot, duration_s=duration_s)
    console.print(render_summary(summarize(log)))

    console.print(Rule("2. replay it as a deterministic test case"))
    passed = replay(log, SYSTEM)
    console.print(render_replay(passed))

    console.print(Rule("3. replay it against a changed behavior"))
    console.print(
        "changed_system: the avoid behavior now reacts 10 cm earlier. The replay fails at the "
        "first cycle where the behaviors no longer do what they did on the robot."
    )
    failed = replay(log, CHANGED_SYSTEM)
    console.print(render_replay(failed))
    if failed.ok:
        console.print(
            "[yellow]This session never came close enough to an obstacle for the change to "
            "matter; run the demo again or record longer (--duration)."
        )
    console.print(f"\nThe log is kept at {log}; try `beatlog show {log}`.")
    return 0 if passed.ok else 1
