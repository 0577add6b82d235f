"""What a shrunk DTC costs against the DTC it was shrunk from, on a 17.5-minute log.

A 35,000-cycle session of a probe (30 ms heartbeats: 17.5 minutes; its one range
reading approaches a pole every 100 cycles, 0.35 m at the nearest) is recorded in a
temporary folder, close to the pole (0.1 m) in one cycle only, late (29,926 by
default). Its spec replays it against ``bench_shrink:fragile_system``, whose dice
raise within 0.3 m of the pole: a bug that depends on no history. ``beatlog shrink``
shrinks the spec (the window found, and whether it starts fresh, are printed), then
the original and the shrunk spec are each run as ``beatlog test`` runs a DTC
(``run_spec``: the verdict, the failure's details and the check that it repeats),
alternated round by round in one process; CPU time by ``time.process_time``, medians
and their ratio printed. The floor is what a fresh start cannot skip: reading and
checking the log's bytes up to the window (``SessionLogReader.batches(start)`` read
to the window's first batch), measured the same way.

``--history`` shrinks ``bench_shrink:weary_system`` instead, whose near raises on its
300th approach to the pole (the one at cycle 29,926): a failure that depends on
history, for which the shrunk window replays the cycles before it.

Run it as ``python bench/bench_shrink.py [--cycles 35000] [--at 29926] [--rounds 5]
[--history]``.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from beatlog.baseline.policy import SpecOptions
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import BehaviorState, PriorityArbiter
from beatlog.model.context import Context, Outputs
from beatlog.model.state import RobotState
from beatlog.record.recorder import Recorder
from beatlog.suite.runner import run_spec
from beatlog.suite.shrink import shrink
from beatlog.suite.spec import load_spec

PERIOD_NS = 30_000_000
WORN_OUT = 300
"""The approach on which :class:`Weary` raises."""


class Range(RobotState, kw_only=True):
    distance: float = 1.0


class Near:
    """Near while the pole is within 0.5 m."""

    name = "near"

    def __init__(self) -> None:
        self.state: BehaviorState = "far"

    def step(self, rs: Range, ctx: Context) -> Outputs | None:
        self.state = "near" if rs.distance < 0.5 else "far"
        return {"speed": 0.0} if self.state == "near" else None


class Weary(Near):
    """Near that raises on its :data:`WORN_OUT`-th approach."""

    def __init__(self) -> None:
        super().__init__()
        self.approaches = 0

    def step(self, rs: Range, ctx: Context) -> Outputs | None:
        was = self.state
        outputs = super().step(rs, ctx)
        if was == "far" and self.state == "near":
            self.approaches += 1
            if self.approaches == WORN_OUT:
                raise RuntimeError("worn out")
        return outputs


class Dice:
    """Draws a die every fifth cycle; its state is the parity."""

    name = "dice"

    def __init__(self) -> None:
        self.state: BehaviorState = "even"

    def step(self, rs: Range, ctx: Context) -> Outputs | None:
        if ctx.cycle % 5 == 0:
            self.state = "odd" if ctx.random.randint(1, 6) % 2 else "even"
        return {"speed": 0.5}


class Fragile(Dice):
    """Dice that raise within 0.3 m of the pole."""

    def step(self, rs: Range, ctx: Context) -> Outputs | None:
        if rs.distance < 0.3:
            raise ZeroDivisionError("fragile dice")
        return super().step(rs, ctx)


def probe_system() -> PriorityArbiter[Range]:
    return PriorityArbiter([Near(), Dice()], robot_state=Range)


def fragile_system() -> PriorityArbiter[Range]:
    return PriorityArbiter([Near(), Fragile()], robot_state=Range)


def weary_system() -> PriorityArbiter[Range]:
    return PriorityArbiter([Weary(), Dice()], robot_state=Range)


def record(path: Path, cycles: int, close_at: int) -> Path:
    """The probe's session: it comes within 0.1 m of the pole in cycle ``close_at``
    alone."""
    with Recorder(
        path, probe_system(), seed=7, software="bench", system_ref="bench_shrink:probe_system"
    ) as recorder:
        for cycle in range(cycles):
            distance = max(abs(((cycle % 100) - 50) / 50), 0.35)
            state = Range(distance=0.1 if cycle == close_at else distance)
            recorder.step(PERIOD_NS + (cycle % 3) * 1000, state)
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
    system = "bench_shrink:weary_system" if args.history else "bench_shrink:fragile_system"
    with tempfile.TemporaryDirectory() as folder:
        log = record(Path(folder) / "long.beatlog", args.cycles, args.at)
        spec = write_spec(Path(folder), log, system)
        started = time.process_time()
        shrunk = shrink(spec)
        shrinking = time.process_time() - started
        how = "fresh start" if shrunk.fresh_start else f"{shrunk.start_cycle} replayed before it"
        print(
            f"{args.cycles} cycles, {system}: fails at cycle {shrunk.failure.cycle}; "
            f"shrunk to window {shrunk.start_cycle}-{shrunk.end_cycle} ({how}) "
            f"in {shrunk.replays} replays, {shrinking:.2f} s CPU"
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
