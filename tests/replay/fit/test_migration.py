"""A state migration names robot-state fields renamed or retyped since a recording; its
converter turns recorded values into the system's types, nested structs and all."""

from __future__ import annotations

import inspect
from typing import Any

import msgspec
import pytest

from beatlog.errors import ConversionError, SystemLoadError
from beatlog.replay.fit.migration import StateConverter, StateMigration
from tests.systems import centimetres_unless_close
from tests.text import frames

NESTED = StateMigration(
    {"pose": "where", "pose.x": "where.px", "battery": "charge"},
    {"charge": "tests.systems:centimetres", "arm.angle": "tests.systems:centimetres"},
)


@pytest.mark.parametrize(
    ("recorded", "current"),
    [
        ("pose", "where"),
        ("pose.x", "where.px"),
        ("pose.y", "where.y"),
        ("battery", "charge"),
        ("arm.angle", "arm.angle"),
    ],
)
def test_a_field_is_named_by_its_path_now_and_as_recorded(recorded: str, current: str) -> None:
    assert NESTED.current_name(recorded) == current
    assert NESTED.recorded_name(current) == recorded


def test_the_fields_converted_each_cycle_are_those_converted_or_renamed_inside() -> None:
    assert NESTED.converted() == {"where", "charge", "arm"}
    assert StateMigration({"battery": "charge"}).converted() == frozenset()


def test_a_migration_is_false_when_empty_and_replays_with_its_options() -> None:
    assert not StateMigration()
    assert StateMigration(conversions={"a": "m:f"})
    assert NESTED.arguments() == (
        "--rename-field",
        "pose=where",
        "--rename-field",
        "pose.x=where.px",
        "--rename-field",
        "battery=charge",
        "--convert-field",
        "charge=tests.systems:centimetres",
        "--convert-field",
        "arm.angle=tests.systems:centimetres",
    )


class Where(msgspec.Struct):
    px: float
    y: float


class Arm(msgspec.Struct):
    angle: int
    length: float = 1.0


class Rover(msgspec.Struct, kw_only=True):
    where: Where
    charge: int
    arm: Arm
    name: str = ""


def as_recorded(**fields: Any) -> Rover:
    """A rover state holding the values as decoded from the log (plain, recorded names)."""
    state = Rover(where=Where(0.0, 0.0), charge=0, arm=Arm(0))
    for name, value in fields.items():
        setattr(state, name, value)
    return state


def test_the_converter_renames_and_converts_recorded_values_into_the_systems_types() -> None:
    state = as_recorded(
        where={"x": 1, "y": 2.5}, charge=0.42, arm={"angle": 0.5, "length": 2.0}, name="r"
    )

    StateConverter(Rover, NESTED)(state)

    assert state == Rover(where=Where(1.0, 2.5), charge=42, arm=Arm(50, 2.0), name="r")
    assert type(state.where) is Where
    assert type(state.where.px) is float


def test_a_conversion_that_raises_names_the_field_and_keeps_the_users_traceback() -> None:
    converter = StateConverter(
        Rover, StateMigration(conversions={"charge": "tests.systems:centimetres_unless_close"})
    )

    with pytest.raises(ConversionError) as raised:
        converter(as_recorded(charge=0.05))

    assert str(raised.value) == (
        "field 'charge': tests.systems:centimetres_unless_close raised ValueError: "
        "0.05 m is too close to convert"
    )
    assert raised.value.user_traceback is not None
    assert (inspect.getsourcefile(centimetres_unless_close), "centimetres_unless_close") in frames(
        raised.value.user_traceback
    )


def test_a_converted_value_of_another_type_than_the_fields_names_the_field() -> None:
    converter = StateConverter(
        Rover, StateMigration(conversions={"arm.angle": "tests.systems:centimetres_as_text"})
    )

    with pytest.raises(ConversionError) as raised:
        converter(as_recorded(arm={"angle": 0.5}))

    assert str(raised.value) == (
        "field 'arm': the recorded value does not fit Arm once converted: "
        "Expected `int`, got `str` - at `$.angle`"
    )
    assert raised.value.user_traceback is None


def test_a_conversion_is_imported_when_the_converter_is_built() -> None:
    with pytest.raises(SystemLoadError) as raised:
        StateConverter(Rover, StateMigration(conversions={"charge": "tests.systems:centimetre"}))

    assert str(raised.value) == (
        "'tests.systems:centimetre': tests.systems has no centimetre (did you mean 'centimetres'?)"
    )
