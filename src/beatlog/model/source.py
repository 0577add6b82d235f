"""The random source behaviors draw from: the only randomness they use, each draw
attributed to the behavior that makes it (:class:`~beatlog.model.random.RecordingRandom`
live, :class:`~beatlog.replay.random.ReplayRandom` in replay).

It speaks both dialects of Python code that draws, :class:`random.Random`'s and numpy's
:class:`numpy.random.Generator`'s, so code written for either takes a behavior's
``context.random`` unchanged. A numpy-style call is recorded as the draw of the same
distribution in the log's kinds (``integers(0, 10)`` as ``randint(0, 9)``,
``normal(size=3)`` as ``normal_array(0.0, 1.0, [3])``); only calls with a ``size``
(and ``integers``, whose scalar is numpy's) need numpy.
"""

from __future__ import annotations

import operator
from abc import ABC, abstractmethod
from bisect import bisect_right
from collections.abc import Sequence
from itertools import accumulate
from math import isclose, prod
from numbers import Integral, Real
from typing import TYPE_CHECKING, Any, Protocol, TypeVar, overload

from beatlog.model.draws import DrawKind, need_numpy

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt


__all__ = ["RandomSource", "Size"]

T = TypeVar("T")
Size = int | Sequence[int]
"""numpy's ``size``: an array's shape, or its length."""


class Stepping(Protocol):
    """What a source reads of the context it is bound to
    (:class:`~beatlog.model.context.Context`), to attribute each draw: the behavior
    stepping (-1 for the system) and the heartbeat's index."""

    actor: int
    cycle: int


class RandomSource(ABC):
    """Random numbers for behaviors, attributed to the behavior that draws them."""

    def __init__(self) -> None:
        self._context: Stepping | None = None

    def bind(self, context: Stepping) -> None:
        """Attach the context whose ``actor`` names the drawing behavior."""
        self._context = context

    @property
    def _actor(self) -> int:
        return -1 if self._context is None else self._context.actor

    @abstractmethod
    def _scalar(self, kind: DrawKind, a: float, b: float, params: tuple[Any, ...]) -> Any: ...

    @abstractmethod
    def _array(self, kind: DrawKind, a: float, b: float, shape: tuple[int, ...]) -> Any: ...

    def _drawn_array(self, kind: DrawKind, low: Any, high: Any, size: Size) -> Any:
        """An array draw of ``size`` between ``low`` and ``high``, numbers the log records
        (numpy's numbers as Python's; an array of bounds, which numpy would broadcast, is
        refused)."""
        return self._array(kind, _number(low), _number(high), _shape(size))

    @overload
    def random(self, size: None = None) -> float: ...
    @overload
    def random(self, size: Size) -> npt.NDArray[np.float64]: ...
    def random(self, size: Size | None = None) -> float | npt.NDArray[np.float64]:
        """A float in [0, 1); with ``size``, an array of them (numpy's ``random``),
        drawn as ``uniform_array(0.0, 1.0, size)``."""
        if size is None:
            return float(self._scalar(DrawKind.RANDOM, 0.0, 1.0, ()))
        return self._drawn_array(DrawKind.UNIFORM_ARRAY, 0.0, 1.0, size)  # type: ignore[no-any-return]

    @overload
    def uniform(self, low: float = 0.0, high: float = 1.0, size: None = None) -> float: ...
    @overload
    def uniform(self, low: float, high: float, size: Size) -> npt.NDArray[np.float64]: ...
    @overload
    def uniform(
        self, low: float = 0.0, high: float = 1.0, *, size: Size
    ) -> npt.NDArray[np.float64]: ...
    def uniform(
        self, low: float = 0.0, high: float = 1.0, size: Size | None = None
    ) -> float | npt.NDArray[np.float64]:
        """A float in [low, high) (``random.Random.uniform(a, b)``, positionally); with
        ``size``, an array of them (numpy's ``uniform``, as ``uniform_array``)."""
        if size is None:
            low, high = _number(low), _number(high)
            return float(self._scalar(DrawKind.UNIFORM, low, high, (low, high)))
        return self._drawn_array(DrawKind.UNIFORM_ARRAY, low, high, size)  # type: ignore[no-any-return]

    def gauss(self, mu: float = 0.0, sigma: float = 1.0) -> float:
        """A normally distributed float with mean ``mu`` and deviation ``sigma``."""
        return float(self._scalar(DrawKind.GAUSS, mu, sigma, (mu, sigma)))

    @overload
    def normal(self, loc: float = 0.0, scale: float = 1.0, size: None = None) -> float: ...
    @overload
    def normal(self, loc: float, scale: float, size: Size) -> npt.NDArray[np.float64]: ...
    @overload
    def normal(
        self, loc: float = 0.0, scale: float = 1.0, *, size: Size
    ) -> npt.NDArray[np.float64]: ...
    def normal(
        self, loc: float = 0.0, scale: float = 1.0, size: Size | None = None
    ) -> float | npt.NDArray[np.float64]:
        """numpy's ``normal``: a normally distributed float with mean ``loc`` and
        deviation ``scale`` (as ``gauss``); with ``size``, an array of them (as
        ``normal_array``)."""
        if size is None:
            loc, scale = _number(loc), _number(scale)
            return float(self._scalar(DrawKind.GAUSS, loc, scale, (loc, scale)))
        return self._drawn_array(DrawKind.NORMAL_ARRAY, loc, scale, size)  # type: ignore[no-any-return]

    def randint(self, a: int, b: int) -> int:
        """An int in [a, b], both ends included (like ``random.randint``)."""
        return int(self._scalar(DrawKind.RANDINT, a, b, (a, b)))

    def integers(
        self,
        low: int,
        high: int | None = None,
        size: Size | None = None,
        dtype: Any = "int64",
        endpoint: bool = False,
    ) -> Any:
        """numpy's ``integers``: an int in [low, high), or [0, low) without ``high``, or
        [low, high] with ``endpoint``; a numpy scalar of ``dtype`` (as
        ``randint(low, high - 1)``), or with ``size`` an array of them (as
        ``integers_array``)."""
        need_numpy()
        import numpy as np  # noqa: PLC0415 - optional: numpy's draws give numpy's types

        low, high = (0, _index(low)) if high is None else (_index(low), _index(high))
        top = high if endpoint else high - 1
        if top < low:
            raise ValueError(f"integers: no int in [{low}, {high}{']' if endpoint else ')'}")
        if size is None:
            return np.dtype(dtype).type(self._scalar(DrawKind.RANDINT, low, top, (low, top)))
        array = self._drawn_array(DrawKind.INTEGERS_ARRAY, low, top + 1, size)
        return array.astype(dtype, copy=False)

    @overload
    def choice(self, a: Sequence[T]) -> T: ...
    @overload
    def choice(
        self,
        a: Any,
        size: Size | None = None,
        replace: bool = True,
        p: Sequence[float] | npt.ArrayLike | None = None,
    ) -> Any: ...
    def choice(
        self,
        a: Any,
        size: Size | None = None,
        replace: bool = True,
        p: Sequence[float] | npt.ArrayLike | None = None,
    ) -> Any:
        """An element of a non-empty sequence, as it is (``random.Random.choice``), or of
        ``range(a)`` for an int ``a`` (numpy's ``choice``), with the probabilities ``p``
        where given; with ``size``, an array of them, without repeats unless ``replace``.

        The pick is drawn as ``choice(n)``, or ``random()`` with ``p`` (the weights are
        applied to it, so replay applies the weights asked for now); with ``size``, as
        ``integers_array`` or ``uniform_array``; without ``replace``, a uniform key per
        element, the smallest ``size`` picked (keys scaled by ``p`` where given).
        """
        population: Any = a
        try:
            count = len(a)
        except TypeError:  # numpy's choice of range(a)
            population, count = None, operator.index(a)
        if count < 1:
            if population is None:
                raise ValueError(f"choice: cannot choose from range({count})")
            raise IndexError("cannot choose from an empty sequence")
        weights = None if p is None else _weights(p, count)
        if size is None:
            if weights is None:
                index = int(self._scalar(DrawKind.CHOICE, 0, count, (count,)))
            else:
                index = _weighted(weights, float(self._scalar(DrawKind.RANDOM, 0.0, 1.0, ())))
            return index if population is None else population[index]
        need_numpy()
        import numpy as np  # noqa: PLC0415 - optional: the arrays extra

        shape = _shape(size)
        if not replace:
            picked = prod(shape)
            if picked > count or (weights is not None and sum(map(bool, weights)) < picked):
                raise ValueError(f"choice: cannot pick {picked} of {count} without repeats")
            keys = self._drawn_array(DrawKind.UNIFORM_ARRAY, 0.0, 1.0, count)
            if weights is not None:
                with np.errstate(divide="ignore"):
                    keys = -np.log1p(-keys) / np.asarray(weights)  # exponential races
            indices = np.argsort(keys, kind="stable")[:picked].reshape(shape)
        elif weights is None:
            indices = self._drawn_array(DrawKind.INTEGERS_ARRAY, 0, count, shape)
        else:
            quantiles = self._drawn_array(DrawKind.UNIFORM_ARRAY, 0.0, 1.0, shape)
            cumulative = np.cumsum(weights)
            at = np.searchsorted(cumulative / cumulative[-1], quantiles, side="right")
            indices = np.minimum(at, np.flatnonzero(weights)[-1])
        return indices if population is None else np.asarray(population)[indices]

    def uniform_array(
        self, low: float, high: float, shape: int | tuple[int, ...]
    ) -> npt.NDArray[np.float64]:
        """A float array of uniform values in [low, high)."""
        return self._drawn_array(DrawKind.UNIFORM_ARRAY, low, high, shape)  # type: ignore[no-any-return]

    def normal_array(
        self, loc: float, scale: float, shape: int | tuple[int, ...]
    ) -> npt.NDArray[np.float64]:
        """A float array of normal values."""
        return self._drawn_array(DrawKind.NORMAL_ARRAY, loc, scale, shape)  # type: ignore[no-any-return]

    def integers_array(
        self, low: int, high: int, shape: int | tuple[int, ...]
    ) -> npt.NDArray[np.int64]:
        """An int array of values in [low, high)."""
        return self._drawn_array(DrawKind.INTEGERS_ARRAY, low, high, shape)  # type: ignore[no-any-return]


def _shape(size: Size) -> tuple[int, ...]:
    """numpy's ``size`` as a shape: a length, or a shape (a sequence or an array)."""
    if isinstance(size, int):
        return (size,)
    if isinstance(size, Integral):  # numpy's ints
        return (operator.index(size),)
    return tuple(map(_index, size))


def _index(value: Any) -> int:
    """An int given as any integer (numpy's too); a float that is a whole number, as
    numpy takes one for a shape."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return operator.index(value)


def _number(value: Any) -> Any:
    """A bound as the log records it: a Python int or float."""
    if isinstance(value, Integral):
        return operator.index(value)
    if isinstance(value, Real):
        return float(value)
    raise TypeError(f"a draw takes a number for each bound, not {value!r}")


def _weights(p: Any, count: int) -> list[float]:
    """numpy's ``p``, checked as numpy checks it: one probability per element, none
    negative, adding up to 1."""
    weights = [float(weight) for weight in p]
    if len(weights) != count:
        raise ValueError(f"choice: {len(weights)} probabilities for {count} elements")
    if min(weights) < 0 or not isclose(sum(weights), 1.0, abs_tol=1e-8):
        raise ValueError("choice: the probabilities p must be non-negative and add up to 1")
    return weights


def _weighted(weights: list[float], quantile: float) -> int:
    """The element whose share of the cumulative ``weights`` holds ``quantile``; never one
    of weight 0."""
    cumulative = list(accumulate(weights))
    index = bisect_right(cumulative, quantile * cumulative[-1])
    return index if index < len(weights) else max(i for i, w in enumerate(weights) if w > 0)
