"""What a shrunk DTC costs against the DTC it was shrunk from, on a 17.5-minute log.

A 35,000-cycle probe session (30 ms heartbeats: 17.5 minutes) is recorded in a
temporary folder, its robot state close to the pole once only, late (cycle 29,926 by
default); the spec replays it against ``tests.systems:fragile_system``, whose dice
raise on a close obstacle, a bug that depends on no history. ``beatlog shrink``
shrinks the spec (its window and fresh start are printed), then the original and the
shrunk spec are each run as ``beatlog test`` runs a DTC (``run_spec``, its details and
the repeat check included), alternated round by round in one process, CPU time by
``time.process_time``; the medians and their ratio are printed. The floor is what
skimming the log up to the window costs alone (``SessionLogReader.batches(start)``
read to the window's first batch), measured the same way.

``--history`` shrinks ``tests.systems:weary_system`` instead, whose near raises on its
fourth approach to the pole: a failure that depends on history, for which the shrunk
window replays the cycles before it.

Run it as ``python bench/bench_shrink.py [--cycles 35000] [--at 29926] [--rounds 5]
[--history]``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from beatlog.baseline.policy import SpecOptions
from beatlog.log.reader import SessionLogReader
from beatlog.record.recorder import Recorder
from beatlog.suite.runner import run_spec
from beatlog.suite.shrink import shrink
from beatlog.suite.spec import load_spec

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the tests' systems
from tests.conftest import PERIOD_NS, Probe, distances, probe_system


def record(path: Path, cycles: int, close_at: int) -> Path:
    """A probe session of ``cycles`` cycles that comes close to the pole (0.1) in cycle
    ``close_at`` alone, and approaches it (0.35 at the nearest) every 100 cycles."""
    with Recorder(
        path, probe_system(), seed=7, software="bench", system_ref="tests.conftest:probe_system"
    ) as recorder:
        for cycle, distance in enumerate(distances(cycles)):
            near = 0.1 if cycle == close_at else max(distance, 0.35)
            recorder.step(PERIOD_NS + (cycle % 3) * 1000, Probe(distance=near))
    return path


def write_spec(folder: Path, log: Path, system: str) -> Path:
    spec = folder / "long.dtc.toml"
    spec.write_text(
        f'name = "long"\npurpose = "bench"\nprocedure = ["bench"]\nlog = "{log.name}"\n'
        f'system = "{system}"\n',
        encoding="utf-8",
    )
    return spec


def cpu(run: Callable[[], object]) -> float:
    started = time.process_time()
    run()
    return time.process_time() - started


def skim(log: Path, start: int) -> None:
    """Read the log up to cycle ``start`` as a fresh start does."""
    with SessionLogReader(log) as reader:
        next(reader.batches(start), None)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=35_000)
    parser.add_argument("--at", type=int, default=29_926, help="the cycle close to the pole")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--history", action="store_true", help="a bug that needs history")
    args = parser.parse_args()
    system = "tests.systems:weary_system" if args.history else "tests.systems:fragile_system"
    with tempfile.TemporaryDirectory() as folder:
        log = record(Path(folder) / "long.beatlog", args.cycles, args.at)
        spec = write_spec(Path(folder), log, system)
        started = time.process_time()
        shrunk = shrink(spec)
        shrinking = time.process_time() - started
        how = "fresh start" if shrunk.fresh_start else "cycles before it replayed"
        print(
            f"{args.cycles} cycles, {system}: fails at cycle {shrunk.cycle}; shrunk to window "
            f"{shrunk.start_cycle}-{shrunk.end_cycle} ({how}) in {shrunk.replays} replays, "
            f"{shrinking:.2f} s CPU"
        )
        original, small = load_spec(spec), load_spec(shrunk.path)
        times: dict[str, list[float]] = {"original": [], "shrunk": [], "floor": []}
        for _ in range(args.rounds):
            times["original"].append(cpu(lambda: run_spec(original, SpecOptions())))
            times["shrunk"].append(cpu(lambda: run_spec(small, SpecOptions())))
            times["floor"].append(cpu(lambda: skim(log, shrunk.start_cycle)))
        medians = {name: statistics.median(values) for name, values in times.items()}
        for name, median in medians.items():
            print(f"{name:>8}: {median * 1000:8.1f} ms CPU (median of {args.rounds})")
        print(f"shrunk / original: {medians['shrunk'] / medians['original']:.1%}")
        print(f"floor / original:  {medians['floor'] / medians['original']:.1%}")


if __name__ == "__main__":
    main()
