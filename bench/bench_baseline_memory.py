"""What a big baseline costs replay in memory: peak RSS against baselines of 16 and 255 MiB.

A car-follower with ``FIELDS`` outputs, each its gain times a gap, is recorded for as
many cycles as a baseline of each size needs; its retuned gain departs from the
recording in every output of every cycle, and the baseline that approves it (what
``beatlog test --update`` writes, written here a block of lines at a time, uncompressed)
is as big as asked. Each figure is measured in a process of its own, as the peak RSS of
its memory since it started (``VmHWM``, Linux: its ``ru_maxrss`` also counts the RSS the
bench had when it forked, which the kernel folds in when the child runs Python): replay
of the log as recorded, without a baseline (the interpreter's own and the log's), and
the retuned system's replay against the baseline, which must pass, having read every
line of it. Reading the baseline alone (checking it whole, then its lines as replay
reads them) is measured too.

Run it as ``python bench/bench_baseline_memory.py [--mib 16 255]``. Nothing here
asserts a timing.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from beatlog.baseline.file import log_digest
from beatlog.baseline.write import COLUMNS, HEADER, format_lines
from beatlog.model.behavior import BehaviorState, PriorityArbiter
from beatlog.model.context import Context, Outputs
from beatlog.model.state import RobotState
from beatlog.record.recorder import Recorder
from beatlog.replay.baseline import TracedOutput

PERIOD_NS = 30_000_000
FIELDS = 16
_LINE_BYTES = 46.3
"""About what a line of the baseline takes (its size is measured, not assumed)."""
HERE = Path(__file__).resolve().parent


class Gap(RobotState, kw_only=True):
    """The distance to the vehicle ahead."""

    distance: float = 1.0


class Follower:
    """Accelerates in proportion to the gap, once per output."""

    name = "follow"

    def __init__(self, gain: float, fields: int) -> None:
        self.state: BehaviorState = "following"
        self.gain = gain
        self.fields = fields

    def step(self, rs: Gap, ctx: Context) -> Outputs:
        return {f"o{i}": self.gain * (rs.distance + i) for i in range(self.fields)}


def wide_system(fields: int = FIELDS) -> PriorityArbiter[Gap]:
    """The car-follower as recorded."""
    return PriorityArbiter([Follower(0.5, fields)], robot_state=Gap)


def wide_system_retuned(fields: int = FIELDS) -> PriorityArbiter[Gap]:
    """The car-follower, its gain retuned by 5 %."""
    return PriorityArbiter([Follower(0.525, fields)], robot_state=Gap)


def _distance(cycle: int) -> float:
    return 1.0 + (cycle % 997) / 1000


def record(log: Path, cycles: int) -> None:
    """Record the car-follower for ``cycles`` cycles."""
    with Recorder(log, wide_system(), seed=3, software="bench") as recorder:
        for cycle in range(cycles):
            recorder.step(PERIOD_NS, Gap(distance=_distance(cycle)))


def write_big_baseline(path: Path, log: Path, cycles: int) -> None:
    """The baseline approving the retuned gain over ``cycles`` cycles of ``log``."""
    follower = Follower(0.525, FIELDS)
    with path.open("w", encoding="utf-8") as file:
        file.write(f"{HEADER}\n# spec big\n# log {log.name} sha256 {log_digest(log)}\n{COLUMNS}\n")
        for start in range(0, cycles, 10_000):
            outputs = [
                TracedOutput(cycle, (cycle + 1) * PERIOD_NS, name, value)
                for cycle in range(start, min(cycles, start + 10_000))
                for name, value in sorted(
                    follower.step(Gap(distance=_distance(cycle)), None).items()  # type: ignore[arg-type]
                )
            ]
            open_loop = (0, PERIOD_NS) if start == 0 else None
            file.write("\n".join(format_lines((), outputs, open_loop=open_loop)) + "\n")


_CHILD = """
import json, resource, sys, time
sys.path.insert(0, {here!r})
from beatlog.baseline.file import read_baseline
from beatlog.replay.judge import replay
what, log, baseline = sys.argv[1:]
started = time.process_time()
figures = {{}}
if what == "bare":
    result = replay(log, "bench_baseline_memory:wide_system")
    figures["ok"] = result.ok
elif what == "read":
    read = read_baseline(__import__("pathlib").Path(baseline))
    figures["lines"] = sum(len(part.outputs) for part in read.stream.parts())
else:
    read = read_baseline(__import__("pathlib").Path(baseline))
    result = replay(log, "bench_baseline_memory:wide_system_retuned", baseline=read.stream)
    figures["ok"] = result.ok
    figures["cycles"] = result.cycles
figures["cpu_s"] = time.process_time() - started
figures["ru_maxrss_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
status = open("/proc/self/status").read().split("VmHWM:")[1].split()
figures["rss_mib"] = int(status[0]) / 1024
print(json.dumps(figures))
"""


def measure(what: str, log: Path, baseline: Path) -> dict[str, Any]:
    """One child process's figures: ``bare`` replay, ``read`` the baseline, or
    ``replay`` against it."""
    child = _CHILD.format(here=str(HERE))
    done = subprocess.run(
        [sys.executable, "-c", child, what, str(log), str(baseline)],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode:
        raise SystemExit(f"{what} failed: {done.stderr.strip().splitlines()[-1]}")
    figures: dict[str, Any] = json.loads(done.stdout)
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--mib", type=float, nargs="+", default=[16.0, 255.0], help="at most 256 (refused past)"
    )
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for mib in args.mib:
            log = Path(folder) / f"big{mib}.beatlog"
            baseline = Path(folder) / f"big{mib}.dtc.expected"
            cycles = int(mib * 2**20 / (FIELDS * _LINE_BYTES))
            record(log, cycles)
            write_big_baseline(baseline, log, cycles)
            size = baseline.stat().st_size
            bare = measure("bare", log, baseline)
            read = measure("read", log, baseline)
            judged = measure("replay", log, baseline)
            if not judged["ok"] or judged["cycles"] != cycles:
                raise SystemExit(f"the replay against the baseline did not pass whole: {judged}")
            row = {
                "baseline_mib": size / 2**20,
                "cycles": cycles,
                "lines": read["lines"],
                "bare_rss_mib": bare["rss_mib"],
                "read_rss_mib": read["rss_mib"],
                "replay_rss_mib": judged["rss_mib"],
                "replay_over_bare_mib": judged["rss_mib"] - bare["rss_mib"],
                "read_cpu_s": read["cpu_s"],
                "replay_cpu_s": judged["cpu_s"],
                "bare_cpu_s": bare["cpu_s"],
            }
            rows.append(row)
            print(
                f"{row['baseline_mib']:7.1f} MiB baseline, {cycles} cycles: peak RSS replay "
                f"{row['replay_rss_mib']:.0f} MiB (bare {row['bare_rss_mib']:.0f} MiB, "
                f"+{row['replay_over_bare_mib']:.0f} MiB), read alone {row['read_rss_mib']:.0f} "
                f"MiB; CPU replay {row['replay_cpu_s']:.1f} s (bare {row['bare_cpu_s']:.1f} s), "
                f"read alone {row['read_cpu_s']:.1f} s",
                flush=True,
            )
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
