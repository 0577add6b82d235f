"""Draws as the log records them: the kinds a behavior may ask for, their recorded
values and parameters, and what makes a recorded one sound.

Scalar draws are pure Python; arrays are packed as ``[dtype, shape, bytes]`` and need
numpy (``pip install "beatlog[arrays]"``) only to be unpacked into one.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from enum import StrEnum
from importlib.util import find_spec
from math import isnan, prod
from numbers import Real
from typing import TYPE_CHECKING, Any

from beatlog.errors import NumpyMissingError
from beatlog.log.format import Draw, payload_encoder

if TYPE_CHECKING:
    import numpy.typing as npt

__all__ = [
    "ARRAY_KINDS",
    "SCALAR_VALUES",
    "DrawKind",
    "need_numpy",
    "pack_array",
    "plain_value",
    "recorded_draw_problem",
    "same_params",
    "unpack_array",
]


class DrawKind(StrEnum):
    """What a behavior asked the random source for."""

    RANDOM = "random"
    """A float in [0, 1)."""
    UNIFORM = "uniform"
    """A float in [a, b)."""
    GAUSS = "gauss"
    """A normally distributed float."""
    RANDINT = "randint"
    """An int in [a, b], both ends included."""
    CHOICE = "choice"
    """An element of a sequence; the index is recorded."""
    UNIFORM_ARRAY = "uniform_array"
    """A numpy array of uniform floats."""
    NORMAL_ARRAY = "normal_array"
    """A numpy array of normal floats."""
    INTEGERS_ARRAY = "integers_array"
    """A numpy array of ints in [low, high)."""


SCALAR_VALUES: dict[str, type[int | float]] = {
    **dict.fromkeys(("random", "uniform", "gauss"), float),
    **dict.fromkeys(("randint", "choice"), int),
}
"""The type of value each scalar kind of draw is recorded with."""
_ARRAY_DTYPES = {
    **dict.fromkeys(("uniform_array", "normal_array"), "<f8"),
    "integers_array": "<i8",
}
"""The dtype each kind of array draw is recorded with (8 bytes an element)."""
ARRAY_KINDS = frozenset(_ARRAY_DTYPES)
_STRUCT_CODES = {"<f8": "d", "<i8": "q"}
"""The :mod:`struct` code of each array draw's dtype, to read one without numpy."""
_PARAMS = {
    **dict.fromkeys(SCALAR_VALUES, 2),
    "random": 0,
    "choice": 1,
    **dict.fromkeys(_ARRAY_DTYPES, 3),
}
"""How many parameters each kind of draw records (none in format 1)."""
_encode_params = payload_encoder().encode
_NUMBERS = frozenset({int, float})


def same_params(recorded: Sequence[Any], asked: Sequence[Any]) -> bool:
    """Whether a draw was asked for with the recorded parameters, one by one: numbers
    by value, exactly (``2`` asks for what ``2.0`` does, as ``-0.0`` does for ``0.0``,
    while ``2.0000001`` does not; NaN matches only NaN), shapes element by element,
    anything else as it encodes in the log."""
    return len(recorded) == len(asked) and all(map(_same_param, recorded, asked))


def _same_param(want: Any, got: Any) -> bool:
    if isinstance(want, list | tuple) and isinstance(got, list | tuple):
        return same_params(want, got)
    if isinstance(want, Real) and isinstance(got, Real):
        return bool(want == got) or (isnan(want) and isnan(got))
    return _encode_params(want) == _encode_params(got)


def pack_array(array: npt.NDArray[Any]) -> tuple[str, list[int], bytes]:
    little = array.astype(array.dtype.newbyteorder("<"), copy=False)
    return (little.dtype.str, list(array.shape), little.tobytes())


def plain_value(draw: Draw) -> Any:
    """A draw's value as plain Python, for reports: an array draw's as nested lists
    (as recorded where those do not make an array). Needs no numpy."""
    if draw.kind not in ARRAY_KINDS or _array_problem(draw.kind, draw.value, ()) is not None:
        return draw.value
    dtype, shape, data = draw.value
    return _nest(list(struct.unpack(f"<{prod(shape)}{_STRUCT_CODES[dtype]}", data)), list(shape))


def _nest(items: list[Any], shape: list[int]) -> Any:
    """``items`` as numpy's ``tolist`` gives an array of ``shape``."""
    if not shape:
        return items[0]
    if len(shape) == 1:
        return items
    step = len(items) // shape[0] if shape[0] else 0
    return [_nest(items[i * step : (i + 1) * step], shape[1:]) for i in range(shape[0])]


def recorded_draw_problem(draw: Draw, behaviors: int) -> str | None:
    """What makes a draw read from a log one that no recording writes, or None: an actor
    outside the catalogue of ``behaviors`` (-1, the system, is in), an unknown kind, a
    value or parameters not of the kind's types, an array whose bytes do not make its
    dtype and shape, a choice outside the recorded range."""
    actor, kind, value, params = draw
    if not -1 <= actor < behaviors:
        return f"drawn by behavior #{actor}, not in the catalogue of {behaviors}"
    arity = _PARAMS.get(kind)
    if arity is None:
        return f"a draw of unknown kind {kind!r}"
    if params and (
        len(params) != arity
        or params[0].__class__ not in _NUMBERS
        or (arity > 1 and params[1].__class__ not in _NUMBERS)
    ):
        return f"{kind} recorded with parameters {list(params)!r}"
    scalar = SCALAR_VALUES.get(kind)
    if scalar is None:
        return _array_problem(kind, value, params)
    if value.__class__ is not scalar:
        return f"{kind} recorded {value!r}, not {'an int' if scalar is int else 'a float'}"
    if kind == "choice" and params and not 0 <= value < params[0]:
        return f"choice recorded index {value} of {params[0]} items"
    return None


def _is_shape(shape: Any) -> bool:
    return shape.__class__ in (list, tuple) and all(n.__class__ is int and n >= 0 for n in shape)


def _array_problem(kind: str, value: Any, params: tuple[Any, ...]) -> str | None:
    """What is wrong with an array draw's recorded ``[dtype, shape, bytes]``, or None."""
    if not (value.__class__ in (list, tuple) and len(value) == 3):
        return f"{kind} recorded {value!r}, not [dtype, shape, bytes]"
    dtype, shape, data = value
    if dtype != _ARRAY_DTYPES[kind]:
        return f"{kind} recorded dtype {dtype!r}, not {_ARRAY_DTYPES[kind]!r}"
    if not _is_shape(shape):
        return f"{kind} recorded shape {shape!r}"
    if params and not (_is_shape(params[2]) and list(params[2]) == list(shape)):
        return f"{kind} recorded shape {list(shape)} where {params[2]!r} was asked for"
    size = 8 * prod(shape)
    if data.__class__ is not bytes or len(data) != size:
        length = len(data) if data.__class__ is bytes else repr(data)
        return f"{kind} recorded {length} bytes for shape {list(shape)}, not {size}"
    return None


def need_numpy() -> None:
    """Make sure numpy, which array draws need (only they do), is installed; where it
    is not, an error that says how to install it."""
    if find_spec("numpy") is None:
        raise NumpyMissingError


def unpack_array(value: Any) -> npt.NDArray[Any]:
    need_numpy()
    import numpy as np  # noqa: PLC0415 - optional: the arrays extra

    dtype, shape, data = value
    return np.frombuffer(data, dtype=np.dtype(dtype)).reshape(shape).copy()
