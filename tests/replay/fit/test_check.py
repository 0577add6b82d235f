"""A log must fit the system it is replayed against: its robot state, type and fields,
and its behaviors."""

from __future__ import annotations

import platform
from pathlib import Path
from typing import Any, Literal

import msgspec
import pytest

from beatlog.errors import FieldError, SchemaMismatchError
from beatlog.model.behavior import Behavior, PriorityArbiter
from beatlog.model.context import Context
from beatlog.model.state import RobotState, state_schema, state_type_name
from beatlog.record.recorder import Recorder
from beatlog.replay.compare import Comparison
from beatlog.replay.core import CycleOutcome
from beatlog.replay.fit.check import check_fit, state_differences
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.judge import replay
from beatlog.replay.verdict import DivergenceKind
from tests.conftest import PERIOD_NS, Dice, Near, Probe, RecordFn, distances, probe_system
from tests.crafting import session_header
from tests.systems import (
    Centimetred,
    PxPose,
    PxPosed,
    Ranged,
    probe_system_centimetred,
    probe_system_ranged,
)


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


def test_a_nested_struct_that_changed_is_named_by_the_fields_that_do_not_fit() -> None:
    assert differences(WithPose, WithPose3) == ["field 'pose.z' is new and has no default"]
    assert differences(WithPose3, WithPose) == ["field 'pose.z' is gone"]


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
    assert message == (
        f"{log}: recorded with robot state tests.conftest.Probe, which does not fit the system's "
        "tests.replay.fit.test_check.Rover: this looks like another robot's log (robot "
        "'robot'): Rover holds only 0 of the 2 fields Probe recorded; field 'distance' is "
        "gone; field 'reading' is gone"
    )
    assert "\n" not in message


class Gauge(RobotState, kw_only=True):
    """The probe's state under another name, one of its two fields renamed since."""

    distance: float = 1.0
    range: float = 0.0


def test_a_state_type_renamed_with_a_field_renamed_is_still_offered_the_rename(
    record_probe: RecordFn,
) -> None:
    log = record_probe(5)
    with pytest.raises(SchemaMismatchError) as raised:
        replay(log, system_with(Gauge))

    assert "another robot's log" not in str(raised.value)
    assert 'add field_renames = { reading = "range" }' in str(raised.value)


def test_a_log_recorded_at_another_heartbeat_period_says_so_and_runs_open_loop(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    faster = PriorityArbiter([Near(), Dice()], robot_state=Probe, period_ns=20_000_000)

    result = replay(log, faster)

    assert result.ok
    assert result.notes == (
        "heartbeat period: the log was recorded at 30 ms, the system runs at 20 ms; the "
        "behaviors replay the recorded heartbeats, so this DTC runs open loop from cycle 0 "
        "(record it again at the new period)",
    )


def test_a_log_recorded_at_the_systems_heartbeat_period_has_no_note(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    same = PriorityArbiter([Near(), Dice()], robot_state=Probe, period_ns=PERIOD_NS)

    assert replay(log, same).notes == ()


def test_a_diverged_replay_under_another_python_than_the_recording_says_so(
    record_probe: RecordFn, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_probe(300)
    recorded = platform.python_version()
    monkeypatch.setattr(platform, "python_version", lambda: "3.99.0")

    result = replay(log, probe_system(threshold=0.6))

    assert not result.ok
    assert result.notes == (
        f"recorded under Python {recorded}, replayed under 3.99.0: Python may compute "
        "otherwise across versions (3.12 adds floats in sum() more exactly), so replay "
        "under the robot's Python to tell a change of code from a change of Python",
    )


def test_a_diverged_replay_under_the_recordings_python_minor_has_no_python_note(
    record_probe: RecordFn, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_probe(300)
    major, minor, _ = platform.python_version_tuple()
    monkeypatch.setattr(platform, "python_version", lambda: f"{major}.{minor}.999")

    result = replay(log, probe_system(threshold=0.6))

    assert (result.ok, result.notes) == (False, ())


def test_a_log_that_ends_early_under_another_python_has_no_python_note(
    record_probe: RecordFn, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_probe(300)
    cut = log.with_name("cut.beatlog")
    cut.write_bytes(log.read_bytes()[:-200])
    monkeypatch.setattr(platform, "python_version", lambda: "3.99.0")

    result = replay(cut, probe_system())

    assert result.divergence is not None
    assert (result.divergence.kind, result.notes) == (DivergenceKind.LOG_ENDED, ())


def test_a_passing_replay_under_another_python_has_no_python_note(
    record_probe: RecordFn, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_probe(300)
    monkeypatch.setattr(platform, "python_version", lambda: "3.99.0")

    result = replay(log, probe_system())

    assert (result.ok, result.notes) == (True, ())


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
        "system's tests.replay.fit.test_check.Grown: Probe is not Grown (a robot state type "
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
    assert (
        result.divergence.message
        == "behavior state changes differ from the recording, and then the behaviors drew 0 random "
        "numbers where 1 were recorded; the next recorded one was a randint drawn by dice"
    )


class Counted(RobotState, kw_only=True):
    """The probe's fields with a whole-number distance."""

    distance: int = 1
    reading: float = 0.0


class Unsure(RobotState, kw_only=True):
    """The probe's fields with a distance that may be unknown."""

    distance: float | None = 1.0
    reading: float = 0.0


class GrownPose(msgspec.Struct):
    x: float
    y: float
    z: float = 0.0


class WithGrownPose(RobotState, kw_only=True):
    pose: GrownPose = msgspec.field(default_factory=lambda: GrownPose(0.0, 0.0))


class Readings(RobotState, kw_only=True):
    readings: list[int] = msgspec.field(default_factory=list)
    counts: dict[str, int] = msgspec.field(default_factory=dict)
    mode: Literal["idle", "run"] = "idle"


class WiderReadings(RobotState, kw_only=True):
    readings: list[float] = msgspec.field(default_factory=list)
    counts: dict[str, float | None] = msgspec.field(default_factory=dict)
    mode: Literal["idle", "run", "dock"] = "idle"


@pytest.mark.parametrize(
    ("recorded", "current"),
    [(Counted, Probe), (Probe, Unsure), (WithPose, WithGrownPose), (Readings, WiderReadings)],
)
def test_a_field_widened_since_fits(
    recorded: type[msgspec.Struct], current: type[msgspec.Struct]
) -> None:
    assert differences(recorded, current) == []


@pytest.mark.parametrize(
    ("recorded", "current", "problems"),
    [
        (Probe, Counted, ["field 'distance' was number, is now integer"]),
        (Unsure, Probe, ["field 'distance' was number|null, is now number"]),
        (
            WiderReadings,
            Readings,
            [
                "field 'readings' was array of number, is now array of integer",
                "field 'counts' was map of number|null, is now map of integer",
                'field \'mode\' was "dock"|"idle"|"run", is now "idle"|"run"',
            ],
        ),
    ],
)
def test_a_field_narrowed_since_does_not_fit(
    recorded: type[msgspec.Struct], current: type[msgspec.Struct], problems: list[str]
) -> None:
    assert differences(recorded, current) == problems


def record_counted(path: Path) -> Path:
    """A probe session whose robot state held its distance as a whole number."""
    system: PriorityArbiter[Any] = PriorityArbiter([Near(1.5), Dice()], robot_state=Counted)
    with Recorder(path, system, seed=7, software="test") as recorder:
        for distance in distances(100):
            recorder.step(PERIOD_NS, Counted(distance=round(distance * 2)))
    return path


def test_an_int_field_that_became_a_float_replays_as_floats(tmp_path: Path) -> None:
    log = record_counted(tmp_path / "counted.beatlog")
    seen: list[Any] = []

    def widened() -> PriorityArbiter[Any]:
        return PriorityArbiter([Near(1.5), Dice()], robot_state=Probe)

    def observe(outcome: CycleOutcome) -> None:
        seen.append(outcome.state.distance)

    assert replay(log, widened()).ok
    assert replay(log, widened(), observe=observe).ok
    assert seen[:3] == [2.0, 2.0, 2.0]
    assert {type(distance) for distance in seen} == {float}


LOG = Path("recorded.beatlog")


def fit(recorded: type[msgspec.Struct], current: type[msgspec.Struct], **migration: Any) -> None:
    """Check that a log recorded with ``recorded`` fits a system of ``current``."""
    header = session_header(
        robot_state_type=state_type_name(recorded), robot_state_schema=state_schema(recorded)
    )
    system: PriorityArbiter[Any] = PriorityArbiter([], robot_state=current)
    check_fit(header, system, LOG, StateMigration(**migration))


def misfit(recorded: type[msgspec.Struct], current: type[msgspec.Struct], **migration: Any) -> str:
    """Why a log recorded with ``recorded`` does not fit ``current``, after the type names."""
    with pytest.raises(SchemaMismatchError) as raised:
        fit(recorded, current, **migration)
    head = (
        f"{LOG}: recorded with robot state {state_type_name(recorded)}, which does not fit "
        f"the system's {state_type_name(current)}: "
    )
    message = str(raised.value)
    assert message.startswith(head)
    return message.removeprefix(head)


def test_a_state_type_fits_each_time_as_it_fitted_the_first() -> None:
    """A system's robot state schema is made once per type (for speed) and shared by
    every check: pinned, checks that rename a field, nested or not, or that fail answer
    alike the first time and after, and a type of another's name checks its own fields."""
    ranged = msgspec.defstruct(  # types new to the process: their first check makes it
        "Ranged", [("range", float, 1.0), ("reading", float, 0.0)], bases=(RobotState,)
    )
    named_alike = msgspec.defstruct(
        "Ranged", [("distance", float, 1.0), ("reading", float, 0.0)], bases=(RobotState,)
    )
    posed = msgspec.defstruct(
        "PxPosed",
        [("pose", PxPose, msgspec.field(default_factory=lambda: PxPose(0.0, 0.0)))],
        bases=(RobotState,),
    )
    answers = []
    for _ in range(2):
        fit(Probe, ranged, renames={"distance": "range"})
        fit(WithPose, posed, renames={"pose.x": "pose.px"})
        fit(Probe, named_alike)
        answers.append([misfit(Probe, ranged), misfit(WithPose, posed), misfit(Probe, posed)])
    assert answers[0] == answers[1]
    assert [answer.count("in its place") for answer in answers[0]] == [1, 1, 0]


def test_a_field_renamed_since_is_bad_input_that_proposes_the_rename(
    record_probe: RecordFn,
) -> None:
    log = record_probe(20)

    with pytest.raises(SchemaMismatchError) as raised:
        replay(log, probe_system_ranged())

    assert str(raised.value) == (
        f"{log}: recorded with robot state tests.conftest.Probe, which does not fit the "
        "system's tests.systems.Ranged: Probe is not Ranged (a robot state type renamed "
        "since keeps exactly its fields); field 'distance' is gone; the system has 'range' "
        '(number) in its place: if renamed, add field_renames = { distance = "range" } '
        "to the spec (beatlog replay: --rename-field distance=range)"
    )


def test_a_field_renamed_by_the_migration_replays_as_recorded(record_probe: RecordFn) -> None:
    log = record_probe(300)

    result = replay(log, probe_system_ranged(), migration=StateMigration({"distance": "range"}))

    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 300, "state_changes": 45, "outputs": 453, "draws": 60, "samples": 0},
    )
    assert result.checked == replay(log, probe_system()).checked
    assert result.reproduce.endswith(" --rename-field distance=range")


class Twice(RobotState, kw_only=True):
    """The probe's two fields, both renamed."""

    dist: float = 1.0
    read: float = 0.0


def test_fields_renamed_inside_a_struct_and_several_at_once_are_proposed() -> None:
    assert misfit(WithPose, PxPosed) == (
        "WithPose is not PxPosed (a robot state type renamed since keeps exactly its "
        "fields); field 'pose.x' is gone; field 'pose.px' is new and has no default; the "
        "system has 'pose.px' (number) in its place: if renamed, add field_renames = "
        '{ "pose.x" = "pose.px" } to the spec (beatlog replay: --rename-field pose.x=pose.px)'
    )
    assert misfit(Probe, Twice).endswith(
        "; the system has 'dist' (number) and 'read' (number) in their place: if renamed, "
        'add field_renames = { distance = "dist", reading = "read" } to the spec (beatlog '
        "replay: --rename-field distance=dist --rename-field reading=read)"
    )
    fit(WithPose, PxPosed, renames={"pose.x": "pose.px"})
    fit(Probe, Twice, renames={"distance": "dist", "reading": "read"})


class Labelled(RobotState, kw_only=True):
    """The probe's distance gone, and a field of another type in its place."""

    label: str = ""
    reading: float = 0.0


def test_a_field_gone_with_no_field_like_it_in_its_place_proposes_nothing() -> None:
    assert misfit(Probe, Labelled) == (
        "Probe is not Labelled (a robot state type renamed since keeps exactly its "
        "fields); field 'distance' is gone"
    )


def test_a_field_retyped_since_is_bad_input_that_proposes_a_conversion() -> None:
    assert misfit(Probe, Centimetred) == (
        "Probe is not Centimetred (a robot state type renamed since keeps exactly its "
        "fields); field 'distance' was number, is now integer; a field retyped since takes "
        'a conversion: field_conversions = { distance = "module:function" } in the spec '
        "(beatlog replay: --convert-field distance=module:function)"
    )
    fit(Probe, Centimetred, conversions={"distance": "tests.systems:centimetres"})


class Flattened(RobotState, kw_only=True):
    pose: Pose = msgspec.field(default_factory=lambda: Pose(0.0, 0.0))
    x: float = 0.0


@pytest.mark.parametrize(
    ("recorded", "current", "migration", "problem"),
    [
        (
            Probe,
            Ranged,
            {"renames": {"distanse": "range"}},
            "field rename distanse -> range: the recorded robot state tests.conftest.Probe "
            "has no field 'distanse' (did you mean 'distance'?)",
        ),
        (
            Probe,
            Ranged,
            {"renames": {"distance": "rang"}},
            "field rename distance -> rang: the system's robot state tests.systems.Ranged "
            "has no field 'rang' (did you mean 'range'?)",
        ),
        (
            WithPose,
            PxPosed,
            {"renames": {"pose.x": "pose.pxx"}},
            "field rename pose.x -> pose.pxx: the system's robot state "
            "tests.systems.PxPosed has no field 'pose.pxx' (did you mean "
            "'pose.px'?)",
        ),
        (
            Probe,
            Ranged,
            {"renames": {"distance": "range", "reading": "range"}},
            "field renames: 'distance' and 'reading' are both renamed to 'range'",
        ),
        (
            Probe,
            Probe,
            {"renames": {"distance": "reading"}},
            "field rename distance -> reading: the log records 'reading' too: rename that as well",
        ),
        (
            WithPose,
            Flattened,
            {"renames": {"pose.x": "x"}},
            "field rename pose.x -> x: a field renamed stays in its struct: it becomes 'pose.x'",
        ),
        (
            Probe,
            Centimetred,
            {"conversions": {"distanse": "tests.systems:centimetres"}},
            "field conversion distanse = tests.systems:centimetres: the system's robot "
            "state tests.systems.Centimetred has no field 'distanse' (did you mean "
            "'distance'?)",
        ),
        (
            Probe,
            Ranged,
            {
                "renames": {"distance": "range"},
                "conversions": {"distance": "tests.systems:centimetres"},
            },
            "field conversion distance = tests.systems:centimetres: a conversion names the "
            "field as it is now: 'range'",
        ),
        (
            Probe,
            Ranged,
            {"conversions": {"range": "tests.systems:centimetres"}},
            "field conversion range = tests.systems:centimetres: the recorded robot state "
            "tests.conftest.Probe has no field 'range' (did you mean 'reading'?)",
        ),
        (
            WithPose,
            PxPosed,
            {"renames": {"pose.x": "pose.px"}, "conversions": {"pose": "tests.systems:pose"}},
            "field conversion pose = tests.systems:pose: 'pose.px' lies inside the field "
            "converted: its conversion maps it",
        ),
    ],
)
def test_a_migration_that_does_not_fit_the_log_and_the_system_is_one_line(
    recorded: type[msgspec.Struct],
    current: type[msgspec.Struct],
    migration: dict[str, Any],
    problem: str,
) -> None:
    with pytest.raises(FieldError) as raised:
        fit(recorded, current, **migration)

    assert str(raised.value) == f"{LOG}: {problem}"


def test_a_robot_state_tolerance_names_a_renamed_field_by_its_current_name(
    record_probe: RecordFn,
) -> None:
    log = record_probe(20)
    renamed = StateMigration({"distance": "range"})
    tolerant = Comparison(state_tolerance={"range": 0.1})

    assert replay(log, probe_system_ranged(), comparison=tolerant, migration=renamed).ok
    with pytest.raises(FieldError, match="robot-state tolerance for 'distance'"):
        replay(
            log,
            probe_system_ranged(),
            comparison=Comparison(state_tolerance={"distance": 0.1}),
            migration=renamed,
        )


def test_a_retyped_field_replays_converted(record_probe: RecordFn) -> None:
    log = record_probe(300)
    converted = StateMigration(conversions={"distance": "tests.systems:centimetres"})

    assert replay(log, probe_system_centimetred(), migration=converted).ok
