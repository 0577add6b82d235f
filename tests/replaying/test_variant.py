"""Variants: a recording replayed with deterministic perturbations, judged by the
behaviors not raising and by the observers that judge, never by the recording."""

from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple

import pytest

from beatlog import replay
from beatlog.errors import FieldError
from beatlog.log.format import CycleRecord
from beatlog.model.behavior import System
from beatlog.replaying.core import CycleOutcome
from beatlog.replaying.variant import Perturbations, Variant, replay_variant, variant_key
from beatlog.replaying.verdict import Divergence, DivergenceKind, ReplayResult
from tests.conftest import PERIOD_NS, RecordFn, distances, probe_system
from tests.perceptions import perceive, record_with_samples
from tests.systems import fussy_system

PERTURBED = Perturbations(heartbeat_jitter=0.002, noise={"distance": 0.05})


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


class Objecting:
    """An observer that judges: it finds cycle ``cycle`` wrong."""

    replaying = reading = True

    def __init__(self, cycle: int) -> None:
        self.cycle = cycle
        self.divergence: Divergence | None = None

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        if outcome is not None and outcome.cycle == self.cycle:
            self.divergence = Divergence(
                DivergenceKind.EXCEPTION, outcome.cycle, outcome.time_ns, "objected"
            )


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


def test_one_variant_twice_draws_perturbs_and_changes_the_same(record_probe: RecordFn) -> None:
    log = record_probe(100)

    first = replayed(log, 3)[1]

    assert replayed(log, 3)[1] == first
    assert len(first) == 100


def test_other_variants_draw_other_numbers_noise_and_jitter(record_probe: RecordFn) -> None:
    log = record_probe(100)

    one, two = (replayed(log, number)[1] for number in (1, 2))

    assert [cycle.heartbeat_ns for cycle in one] != [cycle.heartbeat_ns for cycle in two]
    assert [cycle.distance for cycle in one] != [cycle.distance for cycle in two]
    assert [cycle.drawn for cycle in one] != [cycle.drawn for cycle in two]


def test_the_draws_are_fresh_not_the_recorded_ones(record_probe: RecordFn) -> None:
    log = record_probe(100)

    drawn = [value for cycle in replayed(log, 1, Perturbations())[1] for value in cycle.drawn]

    as_recorded = replayed(log, 1, Perturbations(draws=False))[1]
    recorded = [value for cycle in as_recorded for value in cycle.recorded]
    assert len(drawn) == len(recorded) == 20
    assert drawn != recorded


def test_without_draws_the_recorded_numbers_are_drawn(record_probe: RecordFn) -> None:
    log = record_probe(100)

    cycles = replayed(log, 1, Perturbations(draws=False))[1]

    assert all(cycle.drawn == cycle.recorded for cycle in cycles)
    assert sum(len(cycle.drawn) for cycle in cycles) == 20


def test_noise_and_jitter_stay_within_their_bounds(record_probe: RecordFn) -> None:
    log = record_probe(100)

    cycles = replayed(log, 5)[1]

    recorded = distances(100)
    for t, cycle in enumerate(cycles):
        assert abs(cycle.distance - recorded[t]) <= 0.05
        assert abs(cycle.heartbeat_ns - (PERIOD_NS + (t % 3) * 1000)) <= 2_000_000
    assert len({cycle.distance - recorded[t] for t, cycle in enumerate(cycles)}) == 100
    assert len({cycle.heartbeat_ns for cycle in cycles}) > 90


def test_a_heartbeat_never_drops_below_one_nanosecond(record_probe: RecordFn) -> None:
    log = record_probe(50)

    cycles = replayed(log, 1, Perturbations(heartbeat_jitter=10.0))[1]

    beats = [cycle.heartbeat_ns for cycle in cycles]
    assert min(beats) == 1
    assert cycles[-1].time_ns == sum(beats)


def test_the_key_of_a_variant_is_the_logs_and_its_number() -> None:
    assert variant_key(b"log", 1) == variant_key(b"log", 1)
    assert len({variant_key(b"log", 1), variant_key(b"log", 2), variant_key(b"other", 1)}) == 3


def test_a_noise_bound_naming_no_field_is_one_error_naming_the_spec(
    record_probe: RecordFn, tmp_path: Path
) -> None:
    log = record_probe(20)
    spec = tmp_path / "dock.dtc.toml"

    with pytest.raises(FieldError) as raised:
        replayed(log, 1, Perturbations(noise={"battery": 0.1}), where=spec)

    assert str(raised.value).startswith(f"{spec}: noise bound for 'battery': ")
    assert "has no such field (it has distance, reading)" in str(raised.value)


def test_a_behavior_that_raises_only_under_noise_fails_its_variant(
    record_probe: RecordFn,
) -> None:
    log = record_probe(100, start_time_ns=1_700_000_000_000_000_000)  # its variants keyed
    assert replay(log, fussy_system()).ok  # the recording never reaches the bug

    results = [replayed(log, n, system=fussy_system())[0] for n in range(1, 9)]

    failed = [result for result in results if not result.ok]
    assert failed
    divergence = failed[0].divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.EXCEPTION
    assert divergence.message.startswith("near raised ValueError: a negative distance: -")
    assert divergence.robot_state["distance"] < 0
    assert "raise ValueError" in (divergence.traceback or "")
    assert failed[0].cycles == divergence.cycle + 1  # no cycle replayed past it


def test_unchanged_code_passes_every_variant(record_probe: RecordFn) -> None:
    log = record_probe(100)

    results = [replayed(log, n)[0] for n in range(1, 9)]

    assert all(result.ok for result in results)
    assert {result.cycles for result in results} == {100}
    assert all(result.checked.anything for result in results)


def test_an_observer_that_judges_ends_the_variant(record_probe: RecordFn) -> None:
    log = record_probe(100)
    objecting = Objecting(40)

    result = replay_variant(
        log, probe_system(), Variant(1, PERTURBED), observers=[lambda reader: objecting]
    )

    assert result.divergence is objecting.divergence
    assert result.cycles == 41


def test_a_log_cut_short_fails_a_variant_unless_allowed(record_probe: RecordFn) -> None:
    log = record_probe(100)
    data = log.read_bytes()
    log.write_bytes(data[: len(data) * 2 // 3])

    result = replay_variant(log, probe_system(), Variant(1, PERTURBED))
    allowed = replay_variant(log, probe_system(), Variant(1, PERTURBED), allow_truncated=True)

    assert result.divergence is not None
    assert result.divergence.kind is DivergenceKind.LOG_ENDED
    assert allowed.ok


def perceived(log: Path, perturbations: Perturbations) -> list[float]:
    return [cycle.distance for cycle in replayed(log, 1, perturbations, perception=perceive)[1]]


def test_samples_dropped_leave_the_robot_state_as_it_was(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "sensed.beatlog", 50)

    assert set(perceived(log, Perturbations(drop_samples=1.0))) == {1.0}
    some = perceived(log, Perturbations(drop_samples=0.5))
    assert some != distances(50)
    assert set(some) <= {1.0, *distances(50)}


def test_samples_delayed_arrive_one_cycle_late(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "sensed.beatlog", 50)

    late = perceived(log, Perturbations(delay_samples=1.0))

    assert late == [1.0, *distances(49)]


def test_samples_are_left_alone_without_a_perception_step(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "sensed.beatlog", 50)

    cycles = replayed(log, 1, Perturbations(drop_samples=1.0, draws=False))[1]

    assert [cycle.distance for cycle in cycles] == distances(50)
