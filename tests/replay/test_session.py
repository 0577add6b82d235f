"""The replay session: one log opened once, one replay, observers fed from it."""

from __future__ import annotations

import ast
from dataclasses import dataclass, field
from pathlib import Path

import pytest

import beatlog
from beatlog.errors import SchemaMismatchError
from beatlog.log.format import CycleRecord
from beatlog.replay.core import CycleOutcome
from beatlog.replay.judge import replay
from beatlog.replay.session import FieldsRead, ReplaySession, fields_read
from tests.conftest import RecordFn, probe_system
from tests.systems import moody_system


@dataclass
class Counting:
    """An observer that wants ``replayed`` outcomes and ``read`` cycles in all."""

    replayed: int
    read: int
    outcomes: list[int] = field(default_factory=list)
    records: int = 0

    @property
    def replaying(self) -> bool:
        return len(self.outcomes) < self.replayed

    @property
    def reading(self) -> bool:
        return self.records < self.read

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        self.records += 1
        if outcome is not None:
            self.outcomes.append(outcome.cycle)


def test_observers_get_every_cycle_they_need_from_one_replay(record_probe: RecordFn) -> None:
    log = record_probe(100)
    short, long = Counting(replayed=10, read=20), Counting(replayed=30, read=50)

    with ReplaySession(log, probe_system()) as session:
        session.run([short, long])
        assert session.replayer is not None
        stepped = session.replayer.executor.context.cycle + 1

    assert short.outcomes == list(range(20))  # replayed for the other observer anyway
    assert short.records == 20
    assert long.outcomes == list(range(30))
    assert long.records == 50
    assert stepped == 30


def test_a_replay_stopped_for_everyone_never_resumes(record_probe: RecordFn) -> None:
    log = record_probe(100)
    early, late = Counting(replayed=5, read=40), Counting(replayed=0, read=40)

    with ReplaySession(log, probe_system()) as session:
        session.run([early, late])

    assert early.outcomes == list(range(5))
    assert late.outcomes == [0, 1, 2, 3, 4]  # the cycles replayed for another observer
    assert late.records == 40


def test_without_a_system_observers_read_the_recording_alone(record_probe: RecordFn) -> None:
    reader = Counting(replayed=100, read=100)

    with ReplaySession(record_probe(100), None) as session:
        session.run([reader])
        assert session.replayer is None

    assert (reader.records, reader.outcomes) == (100, [])


def test_a_log_that_does_not_fit_is_refused(record_probe: RecordFn) -> None:
    with pytest.raises(SchemaMismatchError):
        ReplaySession(record_probe(30), moody_system())


def test_the_fields_read_in_a_cycle_are_named_in_order(record_probe: RecordFn) -> None:
    log = record_probe(100)

    assert fields_read(log, probe_system(), 10) == ("distance",)
    assert fields_read(log, probe_system(), 1000) == ()


def test_no_fields_are_read_past_a_cycle_that_did_not_complete(
    record_probe: RecordFn,
) -> None:
    reads = FieldsRead(200)

    with ReplaySession(record_probe(300), probe_system(draws=2)) as session:
        session.run([], fields_read=reads)

    assert reads.fields == ()


def test_the_verdict_and_its_observers_share_one_replay(record_probe: RecordFn) -> None:
    log = record_probe(100)
    counting = Counting(replayed=100, read=100)

    result = replay(log, probe_system(), observers=[lambda reader: counting])

    assert result.ok
    assert (counting.outcomes, counting.records) == (list(range(100)), 100)


def test_observers_of_the_verdicts_replay_take_the_cycles_up_to_its_divergence(
    record_probe: RecordFn,
) -> None:
    log = record_probe(100)
    counting = Counting(replayed=100, read=100)

    result = replay(log, probe_system(threshold=0.6), observers=[lambda reader: counting])

    assert result.divergence is not None
    cycle = result.divergence.cycle
    assert counting.outcomes == list(range(cycle + 1))  # the divergence included
    assert counting.records == cycle + 1


def test_nothing_but_the_replay_session_steps_the_replay_core() -> None:
    package = Path(beatlog.__file__).parent
    stepping = {
        path.relative_to(package).as_posix()
        for path in package.rglob("*.py")
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
        if isinstance(node, ast.Attribute)
        and node.attr == "advance"
        and not ast.unparse(node.value).endswith("clock")  # a heartbeat clock's
    }

    assert sorted(stepping) == ["replay/session.py"]
