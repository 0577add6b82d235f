"""Start-up cost: CPU time of ``import beatlog``, ``beatlog --help`` and the dog's suite
with one and two jobs, each a fresh process, next to a bare interpreter.

CPU time is user + system of the finished child processes (``RUSAGE_CHILDREN``), the
interpreter's own start-up included; wall time is the command's. The commands are
alternated, round after round, and the median of the rounds is printed.

    python bench/bench_startup.py [--rounds 15]
"""

from __future__ import annotations

import argparse
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

from beatlog_examples.dog import SUITE_DIR


def commands() -> dict[str, list[str]]:
    beatlog = shutil.which("beatlog", path=str(Path(sys.executable).parent)) or "beatlog"
    suite = [beatlog, "test", str(SUITE_DIR)]
    return {
        "python -c pass": [sys.executable, "-c", "pass"],
        "python -c 'import beatlog'": [sys.executable, "-c", "import beatlog"],
        "beatlog --help": [beatlog, "--help"],
        "beatlog test -j 1 (dog suite)": [*suite, "-j", "1"],
        "beatlog test -j 2 (dog suite)": [*suite, "-j", "2"],
    }


def measure(command: list[str]) -> tuple[float, float]:
    """CPU and wall seconds of one run of ``command``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    return cpu, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=15)
    args = parser.parse_args()
    runs = commands()
    for command in runs.values():  # warm the file cache
        measure(command)
    cpu: dict[str, list[float]] = {name: [] for name in runs}
    wall: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(args.rounds):
        for name, command in runs.items():
            used, took = measure(command)
            cpu[name].append(used)
            wall[name].append(took)
    print(f"median of {args.rounds} alternated rounds, Python {sys.version.split()[0]}")
    print(f"{'command':34} {'CPU s':>8} {'wall s':>8}")
    for name in runs:
        print(f"{name:34} {statistics.median(cpu[name]):8.3f} {statistics.median(wall[name]):8.3f}")


if __name__ == "__main__":
    main()
