"""Record the patrol tree's DTCs in a toy yard, in lockstep (the yard never waits).

::

    python -m beatlog_examples.trees.record --overwrite             # both, into suite/
    python -m beatlog_examples.trees.record --overwrite --only low-battery  # one case
    python -m beatlog_examples.trees.record some/folder             # somewhere else

Each test case gets its session log ``NAME.beatlog`` and its spec ``NAME.dtc.toml``; a
log already there is kept (recordings are immutable) unless ``--overwrite`` is given.
The yard, the heartbeat jitter and the tree's random numbers are seeded, so
recording again gives the same bytes.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from beatlog import Recorder
from beatlog.errors import LogExistsError
from beatlog.model.context import Outputs
from beatlog.suite import spec
from beatlog.suite.spec import SPEC_SUFFIX
from beatlog_examples.trees import SUITE_DIR
from beatlog_examples.trees.patrol import PatrolState, system

__all__ = ["SCENARIOS", "Scenario", "Yard", "main", "record"]

PERIOD_NS = 50_000_000
JITTER_NS = 3_000_000
SYSTEM_REF = "beatlog_examples.trees:system"


@dataclass(frozen=True)
class Scenario:
    """One recorded session: where the battery starts and when people are in the way."""

    name: str
    purpose: str
    battery: float
    duration_s: float
    crossings: tuple[tuple[float, float], ...]
    """From when to when (s) a person stands in the rover's way."""
    seed: int

    def procedure(self) -> list[str]:
        """How the session was recorded, for the spec."""
        people = ", ".join(f"{start:g}–{end:g} s" for start, end in self.crossings)
        return [
            f"Start the rover in the yard with its battery at {self.battery:.0%}.",
            f"A person stands in its way at {people}.",
            f"Record {self.duration_s:g} s in lockstep: "
            f"python -m beatlog_examples.trees.record --overwrite --only {self.name}",
        ]


SCENARIOS = (
    Scenario(
        "patrol",
        "With a full battery the rover patrols random waypoints, waits while people "
        "cross its path and pauses at each waypoint.",
        battery=0.9,
        duration_s=40.0,
        crossings=((5.0, 8.0), (16.0, 18.5), (29.0, 31.0)),
        seed=11,
    ),
    Scenario(
        "low-battery",
        "With its battery nearly flat the rover heads for the dock; a person blocks it, "
        "so the first docking times out; it docks on the next try and charges until full.",
        battery=0.26,
        duration_s=35.0,
        crossings=((3.0, 12.0),),
        seed=12,
    ),
)


class Yard:
    """A toy world: the battery drains (faster when driving) and charges on the dock,
    people stand in the way, and docking takes ``DOCKING_S`` of driving at the dock
    with a clear way."""

    DOCKING_S = 2.0
    DRAIN_PER_S = 0.001
    DRIVE_DRAIN_PER_S = 0.004
    CHARGE_PER_S = 0.06

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.time_s = 0.0
        self.battery = scenario.battery
        self.docking_s = 0.0

    def state(self) -> PatrolState:
        """What the rover's sensors read now."""
        blocked = any(start <= self.time_s < end for start, end in self.scenario.crossings)
        return PatrolState(
            battery=self.battery,
            obstacle=0.4 if blocked else 5.0,
            docked=self.docking_s >= self.DOCKING_S,
        )

    def advance(self, outputs: Outputs, dt: float) -> None:
        """Apply one cycle's commands for ``dt`` seconds."""
        goal = outputs.get("drive_to")
        if goal == "dock":
            if self.state().obstacle > 1.0:
                self.docking_s += dt
        elif goal is not None:
            self.docking_s = 0.0
        drain = self.DRIVE_DRAIN_PER_S if goal is not None else self.DRAIN_PER_S
        charge = self.CHARGE_PER_S if outputs.get("charge") else 0.0
        self.battery = min(1.0, max(0.0, self.battery + (charge - drain) * dt))
        self.time_s += dt


def record(log: Path, scenario: Scenario, *, overwrite: bool = False) -> int:
    """Record one scenario into ``log`` (``overwrite``: replace a log already there);
    the number of cycles recorded."""
    yard = Yard(scenario)
    jitter = np.random.default_rng(scenario.seed)  # the heartbeat timer's, not the behaviors'
    with Recorder(
        log,
        system(),
        overwrite=overwrite,
        robot_id="patrol-rover",
        system_ref=SYSTEM_REF,
        period_ns=PERIOD_NS,
        seed=scenario.seed,
        software="beatlog-examples",
        start_time_ns=0,
    ) as recorder:
        while recorder.robot_time_ns < scenario.duration_s * 1e9:
            interval_ns = PERIOD_NS + int(jitter.integers(JITTER_NS))
            outputs = recorder.step(interval_ns, yard.state())
            yard.advance(outputs, interval_ns / 1e9)
        return recorder.cycles


def spec_text(scenario: Scenario, log: str) -> str:
    """The ``*.dtc.toml`` for a scenario's recording."""
    return spec.spec_text(
        name=scenario.name,
        purpose=scenario.purpose,
        procedure=scenario.procedure(),
        log=log,
        system=SYSTEM_REF,
        tags=["py_trees"],
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Record the chosen scenarios and write their specs."""
    parser = argparse.ArgumentParser(
        prog="python -m beatlog_examples.trees.record",
        description="Record the patrol tree's DTCs in a toy yard.",
    )
    parser.add_argument("folder", nargs="?", type=Path, default=SUITE_DIR)
    parser.add_argument(
        "--only",
        action="append",
        default=[],
        choices=[scenario.name for scenario in SCENARIOS],
        help="record just this case",
    )
    parser.add_argument(
        "--overwrite", action="store_true", help="replace the logs already in the folder"
    )
    args = parser.parse_args(argv)
    folder: Path = args.folder
    folder.mkdir(parents=True, exist_ok=True)
    for scenario in SCENARIOS:
        if args.only and scenario.name not in args.only:
            continue
        log = folder / f"{scenario.name}.beatlog"
        try:
            cycles = record(log, scenario, overwrite=args.overwrite)
        except LogExistsError as exc:
            parser.exit(2, f"error: {exc.path}: already recorded; --overwrite records it again\n")
        (folder / f"{scenario.name}{SPEC_SUFFIX}").write_text(
            spec_text(scenario, log.name), encoding="utf-8"
        )
        print(f"{scenario.name}: {cycles} cycles into {log}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
