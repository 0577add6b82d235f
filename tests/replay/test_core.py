"""The replay core: advancing a cycle says whether it went cleanly, and its outcome is
what stepping it gives, for cycles that match and cycles that do not."""

from __future__ import annotations

import inspect
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from beatlog.errors import NumpyMissingError, SchemaMismatchError
from beatlog.log.format import CycleRecord, payload_encoder
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import BehaviorState, PriorityArbiter, System
from beatlog.model.context import Context, Outputs
from beatlog.record.recorder import Recorder
from beatlog.replay.core import AGREED, ByteCheck, CycleOutcome, Replayer
from beatlog.replay.draws import DrawMadeOtherwise
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.judge import replay
from beatlog.replay.session import ReplaySession
from tests.conftest import PERIOD_NS, Near, Probe, RecordFn, probe_system
from tests.systems import (
    Fragile,
    Pose,
    Posed,
    PxPose,
    PxPosed,
    Scatter,
    centimetres_unless_close,
    probe_system_centimetred,
)
from tests.text import frames


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
    problem = outcome.refused_draw
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


@dataclass
class Keeping:
    """An observer that keeps what every outcome of the whole log held in its cycle."""

    kept: list[tuple[Any, ...]] = field(default_factory=list)
    replaying: bool = True
    reading: bool = True

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        assert outcome is not None
        self.kept.append(seen(outcome))


@pytest.mark.parametrize("name", SYSTEMS)
def test_observers_see_the_outcomes_the_core_gives_and_advance_answers_the_clean_ones(
    record_probe: RecordFn, name: str
) -> None:
    log = record_probe(120)
    core, records = replayer(log, SYSTEMS[name]())
    answers, outcomes = [], []
    for record in records:
        answers.append(core.advance(record))
        outcomes.append(seen(core.outcome()))  # an outcome holds in its cycle
    keeping = Keeping()

    with ReplaySession(log, SYSTEMS[name]()) as session:
        session.run([keeping])

    assert keeping.kept == outcomes
    completed = [outcome[-1] for outcome in outcomes]
    assert [changes is not None for changes in answers] == completed
    clean = [outcome[4] for outcome in outcomes if outcome[-1]]
    assert [changes for changes in answers if changes is not None] == clean


@pytest.mark.parametrize("name", SYSTEMS)
def test_a_cycle_agrees_at_once_exactly_where_its_bytes_are_the_ones_expected(
    record_probe: RecordFn, name: str
) -> None:
    core, records = replayer(record_probe(120), SYSTEMS[name]())
    core.check_bytes(ByteCheck(None, payload_encoder(), judged=False))
    answers = []
    for record in records:
        changes = core.advance(record)
        outcome = core.outcome()
        clean = changes is not None and outcome.completed
        agrees = clean and outcome.changes is not None and core.agrees(record, outcome.changes)
        answers.append((changes is AGREED, agrees))

    assert [at_once for at_once, _ in answers] == [expected for _, expected in answers]
    judged = [cycle for cycle, (at_once, _) in enumerate(answers) if not at_once]
    assert judged == [] if name == "same" else len(judged) > 1


def test_no_cycle_agrees_at_once_where_the_verdict_judges_every_cycle_whole(
    record_probe: RecordFn,
) -> None:
    core, records = replayer(record_probe(120), probe_system())
    core.check_bytes(ByteCheck(None, payload_encoder(), judged=True))

    answers = [core.advance(record) for record in records]

    assert all(changes is not None and changes is not AGREED for changes in answers)


def test_a_cycle_that_raised_advances_to_none_with_the_failure_in_its_outcome(
    record_probe: RecordFn,
) -> None:
    core, records = replayer(record_probe(120), fragile_system())
    results = [(core.advance(record), core.outcome()) for record in records]
    failed = [outcome for changes, outcome in results if changes is None]
    assert [cycle for cycle, (changes, _) in enumerate(results) if changes is None] == list(
        range(36, 65)
    )  # while the obstacle is close
    assert all(isinstance(outcome.failure, ZeroDivisionError) for outcome in failed)
    assert all(outcome.changes is None for outcome in failed)


def test_a_cycle_after_a_draw_too_many_starts_clean(record_probe: RecordFn) -> None:
    """Dice drawing every 3rd cycle where the recording drew every 5th: cycle 3 draws one
    too many (none was recorded), and cycle 4, which draws nothing, goes cleanly."""
    core, records = replayer(record_probe(10), probe_system(every=3))
    results = [(core.advance(record), core.outcome()) for record in records[:5]]
    assert [changes is not None for changes, _ in results] == [True, True, True, False, True]
    problem = results[3][1].refused_draw
    assert problem is not None
    assert (problem.problem, problem.actor, problem.overdrawn) == (
        "called randint(1, 6) (#1) but only 0 were recorded",
        2,
        True,
    )
    assert results[4][1].refused_draw is None


def test_the_behaviors_see_each_robot_state_as_the_systems_type_itself(
    record_probe: RecordFn,
) -> None:
    """RS_t decoded as the checking subclass (every field the log records required) is
    made the system's type before the behaviors see it, where nothing is converted."""
    seen: list[Any] = []
    result = replay(
        record_probe(40), probe_system(), invariants=[lambda cycle: seen.append(cycle.robot_state)]
    )

    assert result.ok
    assert {type(state) for state in seen} == {Probe}
    assert [state.distance for state in seen[:2]] == [1.0, 0.98]


def test_the_behaviors_see_a_retyped_field_converted(record_probe: RecordFn) -> None:
    log = record_probe(120)
    migration = StateMigration(conversions={"distance": "tests.systems:centimetres"})
    with SessionLogReader(log) as reader:
        core = Replayer(probe_system_centimetred(), reader.header, log, migration=migration)
        states = [(core.advance(record), core.outcome())[1].state for record in reader.cycles()]

    assert [state.distance for state in states[:3]] == [100, 98, 96]
    assert {type(state).__name__ for state in states} == {"Centimetred"}
    assert {type(state.distance) for state in states} == {int}


@pytest.mark.parametrize("observed", [False, True], ids=["with-the-batch", "cycle-by-cycle"])
def test_a_conversion_that_fails_is_bad_input_naming_the_field_and_the_cycle(
    record_probe: RecordFn, observed: bool
) -> None:
    log = record_probe(120)
    migration = StateMigration(conversions={"distance": "tests.systems:centimetres_unless_close"})
    observe = (lambda outcome: None) if observed else None

    with pytest.raises(SchemaMismatchError) as raised:
        replay(log, probe_system_centimetred(), migration=migration, observe=observe)

    assert str(raised.value) == (
        f"{log}: robot state of cycle 46: field 'distance': "
        "tests.systems:centimetres_unless_close raised ValueError: 0.08 m is too close to "
        "convert"
    )
    assert raised.value.user_traceback is not None
    assert (inspect.getsourcefile(centimetres_unless_close), "centimetres_unless_close") in frames(
        raised.value.user_traceback
    )


class Side:
    """Which side of the y axis the robot is on, read from ``pose.x`` (or ``pose.px``)."""

    name = "side"

    def __init__(self, field: str) -> None:
        self.field = field
        self.state: BehaviorState = "left"

    def step(self, rs: Any, ctx: Context) -> Outputs | None:
        self.state = "left" if getattr(rs.pose, self.field) < 0 else "right"
        return None


def test_a_field_renamed_inside_a_struct_reaches_the_behaviors(tmp_path: Path) -> None:
    log = tmp_path / "posed.beatlog"
    recording: PriorityArbiter[Any] = PriorityArbiter([Side("x")], robot_state=Posed)
    with Recorder(log, recording, software="test") as recorder:
        for t in range(20):
            recorder.step(PERIOD_NS, Posed(pose=Pose(x=(-1.0) ** (t // 3), y=t)))
    renamed: PriorityArbiter[Any] = PriorityArbiter([Side("px")], robot_state=PxPosed)
    seen: list[Any] = []

    result = replay(
        log,
        renamed,
        migration=StateMigration({"pose.x": "pose.px"}),
        observe=lambda outcome: seen.append(outcome.state.pose),
    )

    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 20, "state_changes": 7, "outputs": 0, "draws": 0, "samples": 0},
    )
    assert result.checked.state_changes == 7
    assert seen[:4] == [PxPose(1.0, 0.0), PxPose(1.0, 1.0), PxPose(1.0, 2.0), PxPose(-1.0, 3.0)]


def test_a_fresh_array_draw_in_replay_matching_draws_without_numpy_names_the_log_and_the_extra(
    record_probe: RecordFn, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_probe(10)
    with SessionLogReader(log) as reader:
        matching = Replayer(
            PriorityArbiter([Near(), Scatter()], robot_state=Probe),
            reader.header,
            reader.path,
            match_draws=True,
        )
        first = next(reader.cycles())
    monkeypatch.setitem(sys.modules, "numpy", None)

    with pytest.raises(NumpyMissingError) as raised:
        matching.advance(first)

    assert str(raised.value) == (
        f"{log}: array draws (uniform_array, normal_array, integers_array) need numpy: "
        'pip install "beatlog[arrays]"'
    )


@pytest.mark.parametrize("approved", [True, False, None], ids=["approved", "refused", "none"])
def test_a_cycle_whose_draws_differ_agrees_at_once_only_where_they_are_approved(
    record_probe: RecordFn, approved: bool | None
) -> None:
    log = record_probe(60)  # a die rolled every fifth cycle
    asked: list[tuple[int, list[DrawMadeOtherwise]]] = []

    def approves(cycle: int, made: Sequence[DrawMadeOtherwise]) -> bool:
        asked.append((cycle, list(made)))
        return bool(approved)

    with SessionLogReader(log) as reader:
        core = Replayer(probe_system(draws=2), reader.header, reader.path, match_draws=True)
        records = list(reader.cycles())
    core.check_bytes(
        ByteCheck(None, payload_encoder(), False, None if approved is None else approves)
    )
    answers = []
    for record in records:
        changes = core.advance(record)
        outcome = core.outcome()
        as_recorded = outcome.changes is not None and core.agrees(record, outcome.changes)
        answers.append((outcome.cycle, changes is AGREED, as_recorded))

    rolled = [cycle for cycle, _, _ in answers if cycle % 5 == 0]
    assert [cycle for cycle, _ in asked] == ([] if approved is None else rolled)
    assert {made[0] for _, made in asked} <= {DrawMadeOtherwise("dice", None, "randint(1, 6)")}
    agreed = [cycle for cycle, at_once, _ in answers if at_once and cycle % 5 == 0]
    same = [cycle for cycle, _, same in answers if same and cycle % 5 == 0]
    assert agreed == (same if approved else [])
    assert same  # some rolls keep the recorded parity: they agree where approved
