"""What reports cost: ``beatlog test`` against ``test --html`` and ``test --audit``.

CPU time: each command runs as a fresh process, the three alternated round after round,
on the dog's committed suite and on one DTC of a long rover log; a command's
CPU time is user + system of the finished processes it started and waited for, its
workers and audit interpreters included (``resource.getrusage(RUSAGE_CHILDREN)``). The
figure is the median of the rounds, and each ratio is against the plain run's median.

Memory: peak RSS of ``beatlog test --html`` and of a plain ``beatlog test`` on one DTC
of rover logs of two lengths (the longest ``--cycles`` at 30 ms), each measured in a
process of its own (``ru_maxrss`` of the one child it waited for).

Run it as ``python bench/bench_reports.py [--rounds 5] [--cycles 1000000]``. Recording
the long logs takes most of the time (about 45 s per million cycles here). Nothing here
asserts a timing.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from beatlog_examples.rover import record_lockstep

DOG_SUITE = Path(__file__).resolve().parent.parent / "examples/src/beatlog_examples/dog/suite"
ROVER_SYSTEM = "beatlog_examples.rover:system"
ROVER_S = 1050.0
"""Robot time of the rover DTC timed for CPU: 35,000 cycles at 30 ms."""
PERIOD_S = 0.03
BEATLOG = [sys.executable, "-m", "beatlog.cli.main", "test", "-j", "1"]


def rover_dtc(folder: Path, duration_s: float) -> Path:
    """A folder with one spec on a fresh rover log of ``duration_s`` robot time."""
    folder.mkdir(parents=True)
    record_lockstep(folder / "rover.beatlog", duration_s=duration_s, seed=1)
    (folder / "rover.dtc.toml").write_text(
        'name = "rover"\npurpose = "bench"\nprocedure = ["lockstep rover"]\n'
        f'log = "rover.beatlog"\nsystem = "{ROVER_SYSTEM}"\n',
        encoding="utf-8",
    )
    return folder


def children_cpu(command: list[str]) -> float:
    """CPU seconds (user + system) of ``command`` and every process it waited for."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(command, check=True, capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def peak_rss_mb(command: list[str]) -> float:
    """Peak RSS of ``command``, in a process of its own so that no other child counts."""
    probe = (
        "import resource, subprocess, sys; "
        "subprocess.run(sys.argv[1:], check=True, capture_output=True); "
        "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)"
    )
    shown = subprocess.run(
        [sys.executable, "-c", probe, *command], check=True, capture_output=True, text=True
    )
    return int(shown.stdout) / 1024


def cpu_ratios(name: str, suite: Path, report: Path, rounds: int) -> None:
    commands = {
        "test": [*BEATLOG, str(suite)],
        "test --html": [*BEATLOG, str(suite), "--html", str(report)],
        "test --audit": [*BEATLOG, str(suite), "--audit"],
    }
    times: dict[str, list[float]] = {label: [] for label in commands}
    for _ in range(rounds):
        for label, command in commands.items():
            times[label].append(children_cpu(command))
    plain = statistics.median(times["test"])
    for label, measured in times.items():
        median = statistics.median(measured)
        spread = f"{min(measured):.2f}–{max(measured):.2f}"
        print(f"{name}: {label:<13} CPU {median:6.2f} s ({spread}), ratio {median / plain:.2f}")


def memory(folder: Path, cycles: int, report: Path) -> None:
    for share in (2, 1):
        duration_s = cycles // share * PERIOD_S
        suite = rover_dtc(folder / f"rover-{share}", duration_s)
        plain = peak_rss_mb([*BEATLOG, str(suite)])
        html = peak_rss_mb([*BEATLOG, str(suite), "--html", str(report)])
        print(
            f"rover, {duration_s:,.0f} s ({cycles // share:,} cycles): peak RSS "
            f"test {plain:.0f} MB, test --html {html:.0f} MB"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--cycles", type=int, default=1_000_000)
    args = parser.parse_args()
    print(f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory() as temporary:
        folder = Path(temporary)
        report = folder / "report.html"
        cpu_ratios("dog suite", DOG_SUITE, report, args.rounds)
        cpu_ratios("rover 35k", rover_dtc(folder / "rover", ROVER_S), report, args.rounds)
        memory(folder, args.cycles, report)
    print(f"load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
