"""Variants replayed for tests: each cycle's heartbeat, robot state, draws and state
changes noted as the replay goes (:func:`replayed`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple

from beatlog.log.format import CycleRecord
from beatlog.model.behavior import System
from beatlog.replay.core import CycleOutcome
from beatlog.replay.perturbation import Perturbations, Variant
from beatlog.replay.variant import replay_variant
from beatlog.replay.verdict import ReplayResult
from tests.conftest import probe_system

PERTURBED = Perturbations(heartbeat_jitter=0.002, noise={"distance": 0.05})
"""Noise on the probe's distance and a jittered heartbeat, with fresh draws."""


class Seen:
    """An observer that notes, of every cycle of the variant's replay, its heartbeat,
    robot state, draws (recorded and drawn) and state changes."""

    replaying = reading = True

    def __init__(self) -> None:
        self.cycles: list[Cycle] = []

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        if outcome is not None:
            self.cycles.append(
                Cycle(
                    outcome.record.heartbeat_ns,
                    outcome.time_ns,
                    outcome.state.distance,
                    [d.value for d in outcome.recorded_draws],
                    [d.value for d in outcome.drawn],
                    list(outcome.changes or []),
                )
            )


class Cycle(NamedTuple):
    heartbeat_ns: int
    time_ns: int
    distance: float
    recorded: list[Any]
    drawn: list[Any]
    changes: list[Any]


def replayed(
    log: Path,
    number: int,
    perturbations: Perturbations = PERTURBED,
    system: System | None = None,
    **options: Any,
) -> tuple[ReplayResult, list[Cycle]]:
    seen = Seen()
    result = replay_variant(
        log,
        system or probe_system(),
        Variant(number, perturbations),
        observers=[lambda reader: seen],
        **options,
    )
    return result, seen.cycles
