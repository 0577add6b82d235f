"""A draw read from a log that no recording makes is named with what is wrong with it."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import pytest

from beatlog.log.format import Draw
from beatlog.model.draws import recorded_draw_problem, same_params

SIXTEEN = bytes(16)


@pytest.mark.parametrize(
    ("draw", "problem"),
    [
        (Draw(-1, "random", "str", ()), "random recorded 'str', not a float"),
        (Draw(-1, "gauss", 1, (0.0, 1.0)), "gauss recorded 1, not a float"),
        (Draw(-1, "randint", 3.0, (1, 6)), "randint recorded 3.0, not an int"),
        (Draw(-1, "choice", True, (2,)), "choice recorded True, not an int"),
        (Draw(-1, "choice", 2, (2,)), "choice recorded index 2 of 2 items"),
        (Draw(1, "random", 0.5, ()), "drawn by behavior #1, not in the catalogue of 1"),
        (Draw(-2, "random", 0.5, ()), "drawn by behavior #-2, not in the catalogue of 1"),
        (Draw(0, "dice", 4, ()), "a draw of unknown kind 'dice'"),
        (Draw(0, "uniform", 0.5, (2.0,)), "uniform recorded with parameters [2.0]"),
        (Draw(0, "uniform", 0.5, ("a", 5.0)), "uniform recorded with parameters ['a', 5.0]"),
        (
            Draw(0, "uniform_array", ["<i8", [2], SIXTEEN], (0.0, 1.0, [2])),
            "uniform_array recorded dtype '<i8', not '<f8'",
        ),
        (
            Draw(0, "normal_array", ["<f8", [3], SIXTEEN], (0.0, 1.0, [3])),
            "normal_array recorded 16 bytes for shape [3], not 24",
        ),
        (
            Draw(0, "uniform_array", ["<f8", [2], SIXTEEN], (0.0, 1.0, [3])),
            "uniform_array recorded shape [2] where [3] was asked for",
        ),
        (
            Draw(0, "integers_array", ["<i8", [-2], SIXTEEN], ()),
            "integers_array recorded shape [-2]",
        ),
        (
            Draw(0, "integers_array", ["<i8", [2]], ()),
            "integers_array recorded ['<i8', [2]], not [dtype, shape, bytes]",
        ),
    ],
)
def test_a_draw_no_recording_makes_is_named(draw: Draw, problem: str) -> None:
    assert recorded_draw_problem(draw, 1) == problem


NAN = float("nan")


@pytest.mark.parametrize(
    ("recorded", "asked", "same"),
    [
        ((2.0, 5.0), (2, 5), True),
        ((-0.0,), (0.0,), True),
        ((NAN, 1.0), (float("nan"), 1.0), True),
        ((NAN,), (0.0,), False),
        ((2.0,), (2.0000001,), False),
        ((0.0, 1.0), (0.0, 1.5), False),
        ((1,), (True,), True),
        ((0.0, 1.0, [2, 3]), (0.0, 1.0, (2, 3)), True),
        ((0.0, 1.0, [2, 3]), (0.0, 1.0, [3, 2]), False),
        ((0.5,), (Fraction(1, 2),), True),
        (("north",), ("north",), True),
        (("north",), ("south",), False),
        ((1.0,), (1.0, 2.0), False),
        ((), (), True),
    ],
)
def test_a_draw_is_asked_for_with_its_recorded_parameters_exactly_by_value(
    recorded: tuple[Any, ...], asked: tuple[Any, ...], same: bool
) -> None:
    assert (same_params(recorded, asked), same_params(asked, recorded)) == (same, same)
