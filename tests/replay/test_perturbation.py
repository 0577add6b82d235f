"""The perturbations of a variant: the same for one number on every run, other for
another, within their bounds, each from numbers keyed by the log, the number and the
cycle."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from beatlog.errors import FieldError
from beatlog.log.format import CycleRecord
from beatlog.model.behavior import BehaviorState, PriorityArbiter, System
from beatlog.model.context import Context, Outputs
from beatlog.record.recorder import Recorder
from beatlog.replay.core import CycleOutcome
from beatlog.replay.perturbation import Perturbations, Variant, variant_key
from beatlog.replay.variant import replay_variant
from tests.conftest import PERIOD_NS, RecordFn, distances
from tests.perceptions import perceive, record_with_samples
from tests.perturbed import replayed
from tests.systems import Pose, Posed, moody_system, record_moody


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


def test_a_window_starting_mid_batch_is_perturbed_as_the_whole_variant_is(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)

    whole = replayed(log, 4)[1]
    window = replayed(log, 4, start_cycle=101, end_cycle=250)[1]

    assert [(c.heartbeat_ns, c.distance) for c in window] == [
        (c.heartbeat_ns, c.distance) for c in whole[101:251]
    ]


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


class States:
    """An observer that keeps the robot state of every cycle, as the behaviors saw it."""

    replaying = reading = True

    def __init__(self) -> None:
        self.states: list[Any] = []

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        if outcome is not None:
            self.states.append(outcome.state)


def states_of(log: Path, system: System, noise: dict[str, float], **options: Any) -> list[Any]:
    seen = States()
    replay_variant(
        log,
        system,
        Variant(1, Perturbations(noise=noise)),
        observers=[lambda reader: seen],
        **options,
    )
    return seen.states


class Still:
    """A behavior that never changes state: the robot state is all that moves."""

    name = "still"
    state: BehaviorState = "still"

    def step(self, rs: Any, ctx: Context) -> Outputs | None:
        return {"x": rs.pose.x}


def test_noise_on_a_field_of_a_nested_struct_moves_that_field_alone(tmp_path: Path) -> None:
    system: PriorityArbiter[Posed] = PriorityArbiter([Still()], robot_state=Posed)
    with Recorder(tmp_path / "posed.beatlog", system, software="t") as recorder:
        for t in range(20):
            recorder.step(PERIOD_NS, Posed(pose=Pose(x=float(t), y=1.0)))

    states = states_of(tmp_path / "posed.beatlog", system, {"pose.x": 0.1})

    assert [state.pose.y for state in states] == [1.0] * 20
    assert all(abs(state.pose.x - t) <= 0.1 for t, state in enumerate(states))
    assert [state.pose.x for state in states] != [float(t) for t in range(20)]


def test_an_integer_field_moves_by_whole_numbers(tmp_path: Path) -> None:
    log = record_moody(tmp_path / "moody.beatlog")

    states = states_of(log, moody_system(), {"level": 2.0})

    assert all(isinstance(state.level, int) for state in states)
    assert all(abs(state.level - t) <= 2 for t, state in enumerate(states))
    assert [state.level for state in states] != list(range(10))


@pytest.mark.parametrize(("field", "held"), [("mood", "str 'calm'"), ("bumped", "bool False")])
def test_a_noise_bound_on_a_field_holding_no_number_is_one_error_naming_the_spec(
    tmp_path: Path, field: str, held: str
) -> None:
    log = record_moody(tmp_path / "moody.beatlog")
    spec = tmp_path / "moody.dtc.toml"

    with pytest.raises(FieldError) as raised:
        states_of(log, moody_system(), {field: 0.5}, where=spec)

    assert str(raised.value) == (
        f"{spec}: noise bound for {field!r}: the field holds {held}, not a number"
    )


def test_a_noise_bound_naming_no_field_of_a_nested_struct_is_one_error(tmp_path: Path) -> None:
    system: PriorityArbiter[Posed] = PriorityArbiter([Still()], robot_state=Posed)
    with Recorder(tmp_path / "posed.beatlog", system, software="t") as recorder:
        recorder.step(PERIOD_NS, Posed())
    spec = tmp_path / "posed.dtc.toml"

    with pytest.raises(FieldError) as raised:
        states_of(tmp_path / "posed.beatlog", system, {"pose.z": 0.1}, where=spec)

    assert str(raised.value) == (
        f"{spec}: noise bound for 'pose.z': the recorded robot state tests.systems.Posed "
        "has no such field"
    )
