"""The random source: the only randomness behaviors use.

Live, it draws from a counter-based source keyed by its seed and records every value
(RN_t) with what was asked for (the kind and its parameters). Scalar draws are pure
Python; only array draws need numpy (``pip install "beatlog[arrays]"``), imported where
they are made or replayed. In replay it hands back the recorded values; drawing more,
fewer, a different kind or with different parameters than was recorded is a divergence
that names the cycle and the behavior.
"""

from __future__ import annotations

import secrets
import struct
import sys
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from enum import StrEnum
from importlib.util import find_spec
from math import isnan, prod
from numbers import Real
from typing import TYPE_CHECKING, Any, NamedTuple, TypeVar

from beatlog.errors import NumpyMissingError
from beatlog.log.format import Draw, payload_encoder
from beatlog.model.luck import Luck, Place, array_value, fresh_luck, scalar_luck, scalar_value

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    from beatlog.model.context import Context

__all__ = [
    "Draw",
    "DrawDifference",
    "DrawKind",
    "RandomMismatch",
    "RandomSource",
    "RecordingRandom",
    "ReplayRandom",
    "plain_value",
    "recorded_draw_problem",
]

T = TypeVar("T")


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


_ARRAY_KINDS = frozenset(
    {DrawKind.UNIFORM_ARRAY.value, DrawKind.NORMAL_ARRAY.value, DrawKind.INTEGERS_ARRAY.value}
)
_encode_params = payload_encoder().encode
_PLAIN_NUMBERS = frozenset({int, float, bool})
_SCALAR_VALUES: dict[str, type[int | float]] = {
    DrawKind.RANDOM.value: float,
    DrawKind.UNIFORM.value: float,
    DrawKind.GAUSS.value: float,
    DrawKind.RANDINT.value: int,
    DrawKind.CHOICE.value: int,
}
"""The type of value each scalar kind of draw is recorded with."""
_ARRAY_DTYPES = {
    DrawKind.UNIFORM_ARRAY.value: "<f8",
    DrawKind.NORMAL_ARRAY.value: "<f8",
    DrawKind.INTEGERS_ARRAY.value: "<i8",
}
_STRUCT_CODES = {"<f8": "d", "<i8": "q"}
"""The :mod:`struct` code of each array draw's dtype, to read one without numpy."""
"""The dtype each kind of array draw is recorded with (8 bytes an element)."""
_PARAMS = {
    DrawKind.RANDOM.value: 0,
    DrawKind.UNIFORM.value: 2,
    DrawKind.GAUSS.value: 2,
    DrawKind.RANDINT.value: 2,
    DrawKind.CHOICE.value: 1,
    **dict.fromkeys(_ARRAY_DTYPES, 3),
}
"""How many parameters each kind of draw records (none in format 1)."""
_NUMBERS = frozenset({int, float})
_CHOICE = DrawKind.CHOICE.value


def _same_params(recorded: Sequence[Any], asked: Sequence[Any]) -> bool:
    """Whether a draw was asked for with the recorded parameters, one by one: numbers
    by value, exactly (``2`` asks for what ``2.0`` does, as ``-0.0`` does for ``0.0``,
    while ``2.0000001`` does not; NaN matches only NaN), shapes element by element,
    anything else as it encodes in the log."""
    return len(recorded) == len(asked) and all(map(_same_param, recorded, asked))


def _same_param(want: Any, got: Any) -> bool:
    if type(want) in _PLAIN_NUMBERS and type(got) in _PLAIN_NUMBERS:  # the common case
        return want == got or (isnan(want) and isnan(got))
    if isinstance(want, list | tuple) and isinstance(got, list | tuple):
        return _same_params(want, got)
    if isinstance(want, Real) and isinstance(got, Real):
        return bool(want == got) or (isnan(want) and isnan(got))
    return _encode_params(want) == _encode_params(got)


class DrawDifference(NamedTuple):
    """A draw that living replay made otherwise than recorded (see
    :meth:`ReplayRandom.live`): re-mapped, new, or a recorded one left unused."""

    behavior: str
    """The behavior that drew it (that drew it in the recording, for one left unused),
    by its name now."""
    recorded: str | None
    """The recorded request as code (``uniform(0.8, 1.6)``; the kind alone in format 1);
    None for a draw the recording does not have."""
    asked: str | None
    """The request now; None for a recorded draw left unused."""

    def __str__(self) -> str:
        if self.recorded is None:
            return f"{self.behavior}: new {self.asked}"
        if self.asked is None:
            return f"{self.behavior}: {self.recorded} left unused"
        return f"{self.behavior}: {self.recorded} -> {self.asked}"


class RandomMismatch(BaseException):
    """Raised inside behavior code when a replayed draw does not match the recording.

    It derives from BaseException so that a behavior's ``except Exception`` cannot
    swallow it; the source also remembers the mismatch in case it is swallowed anyway.
    """

    def __init__(self, problem: str, actor: int, *, overdrawn: bool) -> None:
        super().__init__(problem)
        self.problem = problem
        self.actor = actor
        self.overdrawn = overdrawn


def _pack_array(array: npt.NDArray[Any]) -> tuple[str, list[int], bytes]:
    little = array.astype(array.dtype.newbyteorder("<"), copy=False)
    return (little.dtype.str, list(array.shape), little.tobytes())


def plain_value(draw: Draw) -> Any:
    """A draw's value as plain Python, for reports: an array draw's as nested lists
    (as recorded where those do not make an array). Needs no numpy."""
    if draw.value is not None and draw.kind in _ARRAY_KINDS:
        try:
            return _nested_lists(draw.value)
        except (ValueError, TypeError, KeyError, struct.error):
            return draw.value
    return draw.value


def _nested_lists(value: Any) -> Any:
    """An array draw's recorded ``[dtype, shape, bytes]`` as numpy's ``tolist`` gives it,
    read in pure Python."""
    dtype, shape, data = value
    if not _is_shape(shape) or len(data) != 8 * prod(shape):
        raise ValueError(f"{len(data)} bytes do not make shape {shape!r}")
    items = list(struct.unpack(f"<{prod(shape)}{_STRUCT_CODES[dtype]}", data))
    return _nest(items, list(shape))


def _nest(items: list[Any], shape: list[int]) -> Any:
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
    scalar = _SCALAR_VALUES.get(kind)
    if scalar is None:
        return _array_problem(kind, value, params)
    if value.__class__ is not scalar:
        return f"{kind} recorded {value!r}, not {'an int' if scalar is int else 'a float'}"
    if kind == _CHOICE and params and not 0 <= value < params[0]:
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


def _need_numpy() -> None:
    """Make sure numpy, which array draws need (only they do), is installed; where it
    is not, an error that says how to install it."""
    if sys.modules.get("numpy") is None and find_spec("numpy") is None:
        raise NumpyMissingError


def _unpack_array(value: Any) -> npt.NDArray[Any]:
    _need_numpy()
    import numpy as np  # noqa: PLC0415 - optional: the arrays extra

    dtype, shape, data = value
    return np.frombuffer(data, dtype=np.dtype(dtype)).reshape(shape).copy()


class RandomSource(ABC):
    """Random numbers for behaviors, attributed to the behavior that draws them."""

    def __init__(self) -> None:
        self._context: Context | None = None

    def bind(self, context: Context) -> None:
        """Attach the context whose ``actor`` names the drawing behavior."""
        self._context = context

    @property
    def _actor(self) -> int:
        return -1 if self._context is None else self._context.actor

    @abstractmethod
    def _scalar(self, kind: DrawKind, a: float, b: float, params: tuple[Any, ...]) -> Any: ...

    @abstractmethod
    def _array(self, kind: DrawKind, a: float, b: float, shape: tuple[int, ...]) -> Any: ...

    def random(self) -> float:
        """A float in [0, 1)."""
        return float(self._scalar(DrawKind.RANDOM, 0.0, 1.0, ()))

    def uniform(self, a: float, b: float) -> float:
        """A float in [a, b)."""
        return float(self._scalar(DrawKind.UNIFORM, a, b, (a, b)))

    def gauss(self, mu: float = 0.0, sigma: float = 1.0) -> float:
        """A normally distributed float with mean ``mu`` and deviation ``sigma``."""
        return float(self._scalar(DrawKind.GAUSS, mu, sigma, (mu, sigma)))

    def randint(self, a: int, b: int) -> int:
        """An int in [a, b], both ends included (like ``random.randint``)."""
        return int(self._scalar(DrawKind.RANDINT, a, b, (a, b)))

    def choice(self, seq: Sequence[T]) -> T:
        """An element of a non-empty sequence."""
        if not seq:
            raise IndexError("cannot choose from an empty sequence")
        index = int(self._scalar(DrawKind.CHOICE, 0, len(seq), (len(seq),)))
        return seq[index]

    def uniform_array(
        self, low: float, high: float, shape: int | tuple[int, ...]
    ) -> npt.NDArray[np.float64]:
        """A float array of uniform values in [low, high)."""
        return self._array(DrawKind.UNIFORM_ARRAY, low, high, _shape(shape))  # type: ignore[no-any-return]

    def normal_array(
        self, loc: float, scale: float, shape: int | tuple[int, ...]
    ) -> npt.NDArray[np.float64]:
        """A float array of normal values."""
        return self._array(DrawKind.NORMAL_ARRAY, loc, scale, _shape(shape))  # type: ignore[no-any-return]

    def integers_array(
        self, low: int, high: int, shape: int | tuple[int, ...]
    ) -> npt.NDArray[np.int64]:
        """An int array of values in [low, high)."""
        return self._array(DrawKind.INTEGERS_ARRAY, low, high, _shape(shape))  # type: ignore[no-any-return]


def _shape(shape: int | tuple[int, ...]) -> tuple[int, ...]:
    return (shape,) if isinstance(shape, int) else tuple(shape)


class RecordingRandom(RandomSource):
    """Draws from a counter-based source keyed by its seed and keeps every value drawn
    in the current cycle.

    The session's n-th draw has the luck of the place ``(0, "", n)`` in the log keyed by
    the seed (:func:`~beatlog.model.luck.fresh_luck`), and the value of its request with
    that luck (:func:`~beatlog.model.luck.scalar_value`): pure Python, the same for the
    same seed on every machine. An array draw seeds numpy's PCG64 from its place
    (:func:`~beatlog.model.luck.array_value`); only array draws need numpy.
    """

    def __init__(self, seed: int | None = None) -> None:
        super().__init__()
        self.seed = seed if seed is not None else secrets.randbits(63)
        self._key = str(self.seed).encode()
        self._count = 0
        self.draws: list[Draw] = []

    def take(self) -> list[Draw]:
        """Hand over this cycle's draws (RN_t) and start an empty list for the next."""
        draws, self.draws = self.draws, []
        return draws

    def _place(self) -> Place:
        """The place keying the next draw: the session's draws counted."""
        self._count += 1
        return Place(0, "", self._count - 1)

    def _scalar(self, kind: DrawKind, a: float, b: float, params: tuple[Any, ...]) -> Any:
        luck = fresh_luck(self._key, self._place())
        value = _SCALAR_VALUES[kind.value](scalar_value(kind.value, params, luck))
        self.draws.append(Draw(self._actor, kind.value, value, params))
        return value

    def _array(self, kind: DrawKind, a: float, b: float, shape: tuple[int, ...]) -> Any:
        _need_numpy()
        params = (a, b, list(shape))
        array = array_value(kind.value, params, None, self._place().seed(self._key))
        self.draws.append(Draw(self._actor, kind.value, _pack_array(array), params))
        return array


class ReplayRandom(RandomSource):
    """Returns the values recorded in RN_t, checking count, kind and parameters as it goes.

    Parameters are compared exactly, as numbers (``uniform(2, 5)`` asks for what
    ``uniform(2.0, 5.0)`` does, and draws the same); a format-1 draw, which recorded
    none, is checked for count and kind only. In *living* replay (:meth:`live`) a draw
    that differs is no mismatch: replay goes on with a value as lucky as the recorded
    one, and the difference is noted for the verdict to judge (:meth:`settle`).
    """

    def __init__(self) -> None:
        super().__init__()
        self.recorded: Sequence[Draw] = ()
        self.drawn: list[Draw] = []
        self.mismatch: RandomMismatch | None = None
        self.living = False
        """Whether draws that differ from the recording go on (:meth:`live`)."""
        self.differences: list[DrawDifference] = []
        """In living replay, the cycle's draws made otherwise than recorded."""
        self._actors: Sequence[int | None] | None = None
        self._recorded_names: Sequence[str] = ()
        self._names_now: Sequence[str] = ()
        self._recorded_now: Sequence[str] = ()
        self._key = b""
        self._used: list[bool] | None = None
        """In living replay, once a draw differed: which recorded draws are taken."""

    def expect_actors(
        self,
        recorded: Sequence[str],
        system: Sequence[str],
        rename: Callable[[str], str] = str,
    ) -> None:
        """Check which behavior draws, too: ``recorded`` is the log's catalogue,
        ``system`` the system's, and ``rename`` maps a recorded name to its name now. A
        draw recorded by a behavior the system no longer has is checked for kind and
        parameters only (in living replay, it is left unused)."""
        ids = {name: index for index, name in enumerate(system)}
        self._actors = [ids.get(rename(name)) for name in recorded]
        self._recorded_names = recorded
        self._names_now = system
        self._recorded_now = [rename(name) for name in recorded]

    def live(self, key: bytes) -> None:
        """Go on when the behaviors ask for other draws than were recorded.

        A behavior's draws are matched with the draws it made in the recording, in
        order, a request of the same kind first: a recorded draw asked for with other
        parameters (or, where sound, as another kind) gives the value with its luck
        (:mod:`beatlog.model.luck`); a request with no recorded draw left gets a fresh
        one keyed by ``key`` (the log) and its place; recorded draws left over are
        dropped. Each is a :class:`DrawDifference`. Same log, same code: same draws.
        """
        self.living = True
        self._key = key

    def load(self, recorded: Sequence[Draw]) -> None:
        """Set the draws recorded for the next cycle."""
        self.recorded = recorded
        if self.drawn:
            self.drawn = []
        if self.differences:
            self.differences = []
        self._used = None
        self.mismatch = None

    def settle(self) -> list[DrawDifference]:
        """In living replay, once the cycle's update is over: its differences, the
        recorded draws left unused among them."""
        used = self._used
        if used is None and len(self.drawn) >= len(self.recorded):  # drew as recorded
            return self.differences
        start = len(self.drawn) if used is None else 0
        for index in range(start, len(self.recorded)):
            if used is None or not used[index]:
                draw = self.recorded[index]
                self.differences.append(
                    DrawDifference(self._recorded_name(draw.actor), _request(draw), None)
                )
        return self.differences

    def _recorded_name(self, actor: int) -> str:
        if actor < 0:
            return "system"
        names = self._recorded_now
        return names[actor] if actor < len(names) else f"#{actor}"

    def _name(self, actor: int) -> str:
        if actor < 0:
            return "system"
        names = self._names_now
        return names[actor] if actor < len(names) else f"#{actor}"

    def _drawn_by(self, draw: Draw, actor: int) -> bool:
        """Whether the recording credits ``draw`` to the behavior ``actor`` is now."""
        actors = self._actors
        if actors is None or draw.actor < 0:
            return draw.actor == actor
        return draw.actor < len(actors) and actors[draw.actor] == actor

    def _next(self, kind: DrawKind, params: tuple[Any, ...]) -> Any:
        index = len(self.drawn)
        actor = self._actor
        if self.living:
            return self._living(kind, params, index, actor)
        if index >= len(self.recorded):
            asked = Draw(actor, kind.value, None, params)
            self._fail(
                f"called {asked.call()} (#{index + 1}) but only {index} were recorded",
                actor,
                overdrawn=True,
                asked=asked,
            )
        draw = self.recorded[index]
        if draw.kind != kind.value or (draw.params and not _same_params(draw.params, params)):
            asked = Draw(actor, kind.value, None, params)
            recorded = draw.call() if draw.params else draw.kind  # format 1 recorded no params
            self._fail(f"called {asked.call()} where {recorded} was recorded", actor, asked=asked)
        if self._actors is not None and draw.actor != actor:
            self._check_actor(draw, actor, kind, params)
        self.drawn.append(Draw(actor, kind.value, draw.value, params))
        return draw.value

    def _living(self, kind: DrawKind, params: tuple[Any, ...], index: int, actor: int) -> Any:
        """A draw in living replay: the recorded one while the cycle follows the
        recording, else the behavior's match (:meth:`live`)."""
        recorded = self.recorded
        if self._used is None:
            if (
                index < len(recorded)
                and recorded[index].kind == kind.value
                and (not recorded[index].params or _same_params(recorded[index].params, params))
                and self._drawn_by(recorded[index], actor)
            ):
                value = recorded[index].value
                self.drawn.append(Draw(actor, kind.value, value, params))
                return value
            self._used = [position < index for position in range(len(recorded))]
        used = self._used
        mine = [i for i, d in enumerate(recorded) if not used[i] and self._drawn_by(d, actor)]
        match = next((i for i in mine if recorded[i].kind == kind.value), None)
        if match is None and kind.value in _SCALAR_VALUES:  # another kind, its luck re-mapped
            match = next((i for i in mine if _luck(recorded[i]) is not None), None)
        place = Place(
            self._context.cycle if self._context is not None else -1,
            self._name(actor),
            sum(1 for d in self.drawn if d.actor == actor),
        )
        value = self._living_value(kind, params, None if match is None else recorded[match], place)
        asked = Draw(actor, kind.value, value, params)
        if match is None:
            self.differences.append(DrawDifference(place.behavior, None, asked.call()))
        else:
            used[match] = True
            draw = recorded[match]
            if draw.kind != kind.value or (draw.params and not _same_params(draw.params, params)):
                self.differences.append(
                    DrawDifference(place.behavior, _request(draw), asked.call())
                )
        self.drawn.append(asked)
        return value

    def _living_value(
        self, kind: DrawKind, params: tuple[Any, ...], draw: Draw | None, place: Place
    ) -> Any:
        """The value of a request with the luck of ``draw`` (fresh where it has none)."""
        if (
            draw is not None
            and draw.kind == kind.value
            and (not draw.params or _same_params(draw.params, params))
        ):
            return draw.value
        if kind.value in _ARRAY_KINDS:
            old = None
            if draw is not None and draw.params:
                old = (draw.kind, draw.params, _unpack_array(draw.value))
            return _pack_array(array_value(kind.value, params, old, place.seed(self._key)))
        luck = None if draw is None else _luck(draw)
        return scalar_value(kind.value, params, luck or fresh_luck(self._key, place))

    def _check_actor(self, draw: Draw, actor: int, kind: DrawKind, params: tuple[Any, ...]) -> None:
        """Refuse a draw the recording credits to another behavior (by its name now)."""
        assert self._actors is not None
        recorded = draw.actor
        if recorded < 0:
            expected: int | None = -1
            who = "the system"
        elif recorded < len(self._actors):
            expected = self._actors[recorded]
            who = self._recorded_names[recorded]
        else:
            return
        if expected is not None and expected != actor:
            asked = Draw(actor, kind.value, None, params)
            self._fail(
                f"called {asked.call()}, which {who} drew in the recording", actor, asked=asked
            )

    def _fail(
        self, problem: str, actor: int, *, overdrawn: bool = False, asked: Draw | None = None
    ) -> None:
        """Raise (and remember) a mismatch; ``asked``, a draw refused, is kept among those
        drawn, with no value, so reports show what was asked for."""
        if asked is not None:
            self.drawn.append(asked)
        self.mismatch = RandomMismatch(problem, actor, overdrawn=overdrawn)
        raise self.mismatch

    def _scalar(self, kind: DrawKind, a: float, b: float, params: tuple[Any, ...]) -> Any:
        value = self._next(kind, params)
        if kind is DrawKind.CHOICE and not 0 <= value < b:
            self._fail(
                f"recorded choice index {value} is out of range for {int(b)} items", self._actor
            )
        return value

    def _array(self, kind: DrawKind, a: float, b: float, shape: tuple[int, ...]) -> Any:
        _need_numpy()  # before a fresh draw of living replay, too
        array = _unpack_array(self._next(kind, (a, b, list(shape))))
        if array.shape != shape:
            self._fail(
                f"drew {kind.value} of shape {shape} where {array.shape} was recorded", self._actor
            )
        return array


def _request(draw: Draw) -> str:
    """A recorded draw's request as code; the kind alone where format 1 recorded none."""
    return draw.call() if draw.params else draw.kind


def _luck(draw: Draw) -> Luck | None:
    """The luck of a recorded scalar draw, where it can be known."""
    if draw.kind == DrawKind.RANDOM.value:
        return scalar_luck(draw.kind, draw.value, ())
    return scalar_luck(draw.kind, draw.value, draw.params) if draw.params else None
