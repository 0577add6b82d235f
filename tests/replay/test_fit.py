"""A log must fit the system it is replayed against: its robot state, type and fields,
and its behaviors."""

from __future__ import annotations

from typing import Any

import msgspec
import pytest

from beatlog.errors import SchemaMismatchError
from beatlog.model.behavior import Behavior, PriorityArbiter
from beatlog.model.context import Context
from beatlog.model.state import RobotState, state_schema
from beatlog.replay.compare import Comparison
from beatlog.replay.fit import state_differences
from beatlog.replay.judge import replay
from beatlog.replay.verdict import DivergenceKind
from tests.conftest import Dice, Near, Probe, RecordFn


class Grown(RobotState, kw_only=True):
    """The probe's fields and one more with a default, under another class name."""

    distance: float = 1.0
    reading: float = 0.0
    battery: float = 1.0


class Later:
    """The probe's module a version later."""

    class Probe(RobotState, kw_only=True):
        """The probe state after gaining a field with a default: old logs still load."""

        distance: float = 1.0
        reading: float = 0.0
        battery: float = 1.0


class Renamed(RobotState, kw_only=True):
    """The probe's fields under another class name."""

    distance: float = 1.0
    reading: float = 0.0


class Retyped(RobotState, kw_only=True):
    distance: str = "far"
    reading: float = 0.0


class Shrunk(RobotState, kw_only=True):
    distance: float = 1.0


class Demanding(RobotState, kw_only=True):
    distance: float = 1.0
    reading: float = 0.0
    battery: float


class Pose(msgspec.Struct):
    x: float
    y: float


class Pose3(msgspec.Struct):
    x: float
    y: float
    z: float


class WithPose(RobotState, kw_only=True):
    pose: Pose = msgspec.field(default_factory=lambda: Pose(0.0, 0.0))


class WithPose3(RobotState, kw_only=True):
    pose: Pose3 = msgspec.field(default_factory=lambda: Pose3(0.0, 0.0, 0.0))


class Rover(RobotState, kw_only=True):
    """Another robot's state altogether."""

    x: float = 0.0
    heading: float = 0.0
    bumped: bool = False


def differences(recorded: type[msgspec.Struct], current: type[msgspec.Struct]) -> list[str]:
    return state_differences(state_schema(recorded), state_schema(current))


@pytest.mark.parametrize("current", [Probe, Later.Probe, Renamed])
def test_the_same_fields_or_new_ones_with_defaults_fit(current: type[msgspec.Struct]) -> None:
    assert differences(Probe, current) == []


@pytest.mark.parametrize(
    ("current", "problem"),
    [
        (Retyped, "field 'distance' was number, is now string"),
        (Shrunk, "field 'reading' is gone"),
        (Demanding, "field 'battery' is new and has no default"),
    ],
)
def test_a_field_gone_retyped_or_required_does_not_fit(
    current: type[msgspec.Struct], problem: str
) -> None:
    assert differences(Probe, current) == [problem]


def test_a_nested_struct_that_changed_does_not_fit() -> None:
    assert differences(WithPose, WithPose3) == ["field 'pose' was Pose, is now Pose3"]


def test_another_robots_state_names_every_field_that_does_not_fit() -> None:
    assert differences(Probe, Rover) == ["field 'distance' is gone", "field 'reading' is gone"]


def system_with(state: type[RobotState]) -> PriorityArbiter[Any]:
    return PriorityArbiter([Near()], robot_state=state)


def test_replay_against_another_robots_state_is_bad_input_naming_both(
    record_probe: RecordFn,
) -> None:
    log = record_probe(5)
    with pytest.raises(SchemaMismatchError) as raised:
        replay(log, system_with(Rover))
    message = str(raised.value)
    assert message.startswith(f"{log}: recorded with robot state tests.conftest.Probe")
    assert "does not fit the system's tests.replay.test_fit.Rover" in message
    assert "field 'distance' is gone" in message
    assert "\n" not in message


def test_a_state_that_gained_a_field_with_a_default_still_replays(record_probe: RecordFn) -> None:
    log = record_probe(20)
    grown: PriorityArbiter[Any] = PriorityArbiter([Near(), Dice()], robot_state=Later.Probe)
    assert replay(log, grown).ok


def test_a_state_renamed_with_the_same_fields_still_replays(record_probe: RecordFn) -> None:
    log = record_probe(20)
    renamed: PriorityArbiter[Any] = PriorityArbiter([Near(), Dice()], robot_state=Renamed)
    assert replay(log, renamed).ok


def test_another_type_that_holds_the_recorded_fields_among_more_does_not_fit(
    record_probe: RecordFn,
) -> None:
    log = record_probe(20)
    with pytest.raises(SchemaMismatchError) as raised:
        replay(log, PriorityArbiter([Near(), Dice()], robot_state=Grown))
    assert str(raised.value) == (
        f"{log}: recorded with robot state tests.conftest.Probe, which does not fit the "
        "system's tests.replay.test_fit.Grown: Probe is not Grown (a robot state type "
        "renamed since keeps exactly its fields)"
    )


class Pair:
    """The probe's two behaviors under other names, stepped in turn with no arbiter."""

    robot_state = Probe

    def __init__(self, near: str = "close", dice: str = "die") -> None:
        self._near, self._dice = Near(), Dice()
        self.behaviors: dict[str, Behavior] = {near: self._near, dice: self._dice}

    def update(self, state: Probe, context: Context) -> None:
        context.actor = 0  # draws are credited to the behavior drawing
        self._near.step(state, context)
        context.actor = 1
        self._dice.step(state, context)
        context.actor = -1


def test_a_log_none_of_whose_behaviors_is_the_systems_does_not_fit(
    record_probe: RecordFn,
) -> None:
    log = record_probe(20)
    with pytest.raises(SchemaMismatchError) as raised:
        replay(log, Pair())
    assert str(raised.value) == (
        f"{log}: the log's behaviors arbiter, near, dice are not the system's (close, die): "
        "another robot's log? (behaviors renamed since the recording are mapped with "
        "renames in the spec)"
    )


def test_behaviors_renamed_by_the_spec_fit_and_are_judged(record_probe: RecordFn) -> None:
    log = record_probe(20)
    renames = Comparison(renames={"near": "close", "dice": "die"})
    result = replay(log, Pair(), comparison=renames)
    assert result.divergence is not None
    assert result.divergence.kind is DivergenceKind.STATE_CHANGES


def test_draws_of_a_behavior_the_system_lacks_are_named_from_the_recording(
    record_probe: RecordFn,
) -> None:
    log = record_probe(20)
    result = replay(log, system_with(Probe))
    assert result.divergence is not None
    assert "drawn by dice" in result.divergence.message
