"""The replay core: advancing a cycle says whether it went cleanly, and its outcome is
what stepping it gives, for cycles that match and cycles that do not."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from beatlog.log.format import CycleRecord
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import PriorityArbiter, System
from beatlog.replay.core import CycleOutcome, Replayer
from tests.conftest import Near, Probe, RecordFn, probe_system
from tests.systems import Fragile


def fragile_system() -> PriorityArbiter[Probe]:
    return PriorityArbiter([Near(), Fragile()], robot_state=Probe)


SYSTEMS: dict[str, Callable[[], System]] = {
    "same": probe_system,
    "changed": lambda: probe_system(threshold=0.6),
    "overdrawing": lambda: probe_system(draws=2),
    "underdrawing": lambda: probe_system(every=10),
    "raising": fragile_system,
}


def replayer(log: Path, system: System) -> tuple[Replayer, list[CycleRecord]]:
    with SessionLogReader(log) as reader:
        return Replayer(system, reader.header, reader.path), list(reader.cycles())


def seen(outcome: CycleOutcome) -> tuple[Any, ...]:
    """An outcome's fields, with what was raised by its type and message."""
    problem = outcome.draw_problem
    return (
        outcome.cycle,
        outcome.time_ns,
        outcome.record,
        outcome.state,
        outcome.changes,
        dict(outcome.outputs),
        list(outcome.recorded_draws),
        list(outcome.drawn),
        None if problem is None else (problem.problem, problem.actor, problem.overdrawn),
        None if outcome.failure is None else repr(outcome.failure),
        outcome.actor,
        outcome.completed,
    )


@pytest.mark.parametrize("name", SYSTEMS)
def test_advancing_then_asking_for_the_outcome_is_stepping(
    record_probe: RecordFn, name: str
) -> None:
    log = record_probe(120)
    stepper, records = replayer(log, SYSTEMS[name]())
    advancer, _ = replayer(log, SYSTEMS[name]())
    for record in records:
        stepped = stepper.step(record)
        changes = advancer.advance(record)
        outcome = advancer.outcome()
        assert seen(outcome) == seen(stepped)
        assert (changes is not None) == outcome.completed
        if changes is not None:
            assert changes == outcome.changes


def test_a_cycle_that_raised_advances_to_none_with_the_failure_in_its_outcome(
    record_probe: RecordFn,
) -> None:
    core, records = replayer(record_probe(120), fragile_system())
    results = [(core.advance(record), core.outcome()) for record in records]
    failed = [outcome for changes, outcome in results if changes is None]
    assert failed
    assert all(isinstance(outcome.failure, ZeroDivisionError) for outcome in failed)
    assert all(outcome.changes is None for outcome in failed)


def test_a_cycle_after_a_draw_too_many_starts_clean(record_probe: RecordFn) -> None:
    """Dice drawing every 3rd cycle where the recording drew every 5th: cycle 3 draws one
    too many (none was recorded), and cycle 4, which draws nothing, goes cleanly."""
    core, records = replayer(record_probe(10), probe_system(every=3))
    results = [(core.advance(record), core.outcome()) for record in records[:5]]
    assert [changes is not None for changes, _ in results] == [True, True, True, False, True]
    problem = results[3][1].draw_problem
    assert problem is not None
    assert problem.overdrawn
    assert results[4][1].draw_problem is None
