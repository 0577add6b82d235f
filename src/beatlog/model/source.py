"""The random source behaviors draw from: the only randomness they use, each draw
attributed to the behavior that makes it (:class:`~beatlog.model.random.RecordingRandom`
live, :class:`~beatlog.model.replay_random.ReplayRandom` in replay)."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, TypeVar

from beatlog.model.draws import DrawKind

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    from beatlog.model.context import Context

__all__ = ["RandomSource"]

T = TypeVar("T")


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
