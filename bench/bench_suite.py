"""Suite runner overhead: ``beatlog test`` on N specs against their summed replay time.

The target: ``beatlog test -j J`` on N specs takes at most 1.2 × (sum of the specs'
replay times) / J, plus start-up. Start-up is measured as the same command on J
specs of a ten-cycle log (interpreter, imports, worker pool); the replay times are
``run_spec`` on each spec in this process. All are measured in this one run.

The same replays take longer when two run at once on this machine, so the script
also reports the replay times the workers measured (from the JUnit report) and the
runner's own overhead against those: what the runner adds beyond the machine.

Run it as ``python bench/bench_suite.py [--specs N] [--jobs J]``; about a minute on
2 cores.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

from rich.console import Console
from rich.table import Table

from beatlog.suite.runner import run_spec
from beatlog.suite.spec import load_spec, spec_text
from beatlog_examples.rover import record_lockstep

SYSTEM = "beatlog_examples.rover:system"
DURATION_S = 1050.0
"""Robot time of each spec's log: 17.5 minutes, 35,000 cycles at 30 ms."""
REPEATS = 5


def bench_spec(name: str, log: str) -> str:
    """The spec of one benchmark DTC: a lockstep rover log against the rover's system."""
    return spec_text(
        name=name, purpose="bench", procedure=["lockstep rover"], log=log, system=SYSTEM
    )


def write_specs(folder: Path, log: Path, count: int) -> list[Path]:
    folder.mkdir(parents=True)
    paths = []
    for index in range(count):
        path = folder / f"dtc-{index:02}.dtc.toml"
        path.write_text(bench_spec(f"dtc-{index:02}", os.path.relpath(log, folder)), "utf-8")
        paths.append(path)
    return paths


def suite_wall(folder: Path, jobs: int) -> tuple[float, float]:
    """Wall time of ``beatlog test`` and the sum of the replay times its workers took."""
    junit = folder.parent / f"{folder.name}.xml"
    command = [sys.executable, "-m", "beatlog.cli.main", "test", "-j", str(jobs)]
    started = time.perf_counter()
    subprocess.run(
        [*command, "--junit-xml", str(junit), str(folder)], check=True, capture_output=True
    )
    wall = time.perf_counter() - started
    cases = ET.parse(junit).getroot().iter("testcase")
    return wall, sum(float(case.attrib["time"]) for case in cases)


def replay_time(spec: Path) -> float:
    outcome = run_spec(load_spec(spec))
    assert outcome.result is not None
    assert outcome.result.ok
    return outcome.wall_time_s


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--specs", type=int, default=12, help="specs in the suite")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="workers")
    args = parser.parse_args()
    console = Console()
    with tempfile.TemporaryDirectory() as scratch:
        root = Path(scratch)
        long_log, short_log = root / "long.beatlog", root / "short.beatlog"
        record_lockstep(long_log, duration_s=DURATION_S, seed=1)
        record_lockstep(short_log, duration_s=0.3, seed=1)
        specs = write_specs(root / "suite", long_log, args.specs)
        write_specs(root / "startup", short_log, args.jobs)

        run_spec(load_spec(specs[0]))  # warm the page cache and imports
        sums, startups, runs = [], [], []
        for _ in range(REPEATS):  # alternately, so a slow stretch of the machine hits all
            sums.append(sum(replay_time(path) for path in specs))
            startups.append(suite_wall(root / "startup", args.jobs)[0])
            runs.append(suite_wall(root / "suite", args.jobs))
        replay_sum, startup, (wall, worker_sum) = min(sums), min(startups), min(runs)

    ideal = replay_sum / args.jobs
    ratio = (wall - startup) / ideal
    runner = (wall - startup) / (worker_sum / args.jobs)
    table = Table(title=f"beatlog test: {args.specs} specs of 35,000 cycles, -j {args.jobs}")
    table.add_column("figure")
    table.add_column("value", justify="right")
    table.add_row("sum of replay times (run_spec, one process)", f"{replay_sum:.2f} s")
    table.add_row(f"ideal: sum / {args.jobs} workers", f"{ideal:.2f} s")
    table.add_row(f"start-up: beatlog test on {args.jobs} ten-cycle specs", f"{startup:.2f} s")
    table.add_row("beatlog test on the suite (wall)", f"{wall:.2f} s")
    table.add_row("(wall − start-up) / ideal   target ≤ 1.2", f"{ratio:.2f}")
    table.add_row("sum of replay times the workers measured", f"{worker_sum:.2f} s")
    table.add_row("  / sum in one process (two replays at once)", f"{worker_sum / replay_sum:.2f}")
    table.add_row("(wall − start-up) / (workers' sum / workers)", f"{runner:.2f}")
    console.print(table)
    verdict = "met" if ratio <= 1.2 else "MISSED"
    console.print(f"best of {REPEATS} for each command; target {verdict}")


if __name__ == "__main__":
    main()
