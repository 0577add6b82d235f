"""The random source that records: the only randomness behaviors use, live.

It draws from a counter-based source keyed by its seed and records every value (RN_t)
with what was asked for (the kind and its parameters); in replay the recorded values
are handed back (:mod:`beatlog.replay.random`), and drawing more, fewer, another kind
or other parameters is a divergence. Only array draws need numpy. The interface
behaviors draw from (:mod:`.source`) and the draws' kinds are importable from here too.
"""

from __future__ import annotations

import secrets
from typing import Any

from beatlog.log.format import Draw
from beatlog.model.draws import (
    SCALAR_VALUES,
    DrawKind,
    need_numpy,
    pack_array,
    plain_value,
    recorded_draw_problem,
)
from beatlog.model.quantiles import FreshQuantiles, Place, array_value, scalar_value
from beatlog.model.source import RandomSource

__all__ = [
    "Draw",
    "DrawKind",
    "RandomSource",
    "RecordingRandom",
    "plain_value",
    "recorded_draw_problem",
]


class RecordingRandom(RandomSource):
    """Draws from a counter-based source keyed by its seed and keeps every value drawn
    in the current cycle: the session's n-th draw is its request's value at the quantile
    of the place ``(0, "", n)`` (:class:`~beatlog.model.quantiles.FreshQuantiles`), the
    same for the same seed on every machine."""

    def __init__(self, seed: int | None = None) -> None:
        super().__init__()
        self.seed = seed if seed is not None else secrets.randbits(63)
        self._fresh = FreshQuantiles(str(self.seed).encode())
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
        quantile = self._fresh.quantile(self._place())
        value = SCALAR_VALUES[kind.value](scalar_value(kind.value, params, quantile))
        self.draws.append(Draw(self._actor, kind.value, value, params))
        return value

    def _array(self, kind: DrawKind, a: float, b: float, shape: tuple[int, ...]) -> Any:
        need_numpy()
        params = (a, b, list(shape))
        array = array_value(kind.value, params, None, self._fresh.seed(self._place()))
        self.draws.append(Draw(self._actor, kind.value, pack_array(array), params))
        return array
