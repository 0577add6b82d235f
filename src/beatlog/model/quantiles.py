"""A draw's quantile: what lets a recorded random number survive a change of its request.

Every draw is a value of a distribution; its *quantile* is where in that distribution it
fell: a uniform in [0, 1) (for a normal draw, its standard score as well). When a
behavior now asks for another request than was recorded (``uniform(0.8, 1.6)`` retuned
to ``uniform(0.7, 1.5)``), replay hands it the value of the new request at the
recorded quantile, so the retuned behavior is as lucky as the robot was. A draw the
recording never had gets a fresh quantile from a counter-based source keyed by the log
and the draw's place (cycle, behavior, call): the same on every machine and under any
hash seed, never a global generator.

Mappings, and where none is sound:

- scalar to scalar, any of ``random``, ``uniform``, ``gauss``, ``randint`` and
  ``choice``: by quantile (a normal draw to a normal draw by its standard score, so a
  changed deviation scales the same deviate); an integer draw's quantile is the middle of
  its value's share of [0, 1), so the same request gives back the same value;
- an array to an array of the same kind: element by element; a grown array's new
  elements are fresh;
- an array to another kind of array, a scalar to an array or back, and a format-1 draw
  (which recorded no request, so its quantile is unknown) to another kind: none; the
  request gets a fresh draw and the recorded one is left unused.
"""

from __future__ import annotations

import hashlib
import math
from statistics import NormalDist
from typing import TYPE_CHECKING, Any, NamedTuple

if TYPE_CHECKING:
    import numpy.typing as npt

__all__ = [
    "FreshQuantiles",
    "Place",
    "Quantile",
    "array_value",
    "scalar_quantile",
    "scalar_value",
]

_NORMAL = NormalDist()
_SQRT2 = math.sqrt(2.0)
_TINY = 2.0**-53
_TOP = 1.0 - _TINY
_SCALARS = frozenset({"random", "uniform", "gauss", "randint", "choice"})


class Quantile(NamedTuple):
    """Where a draw fell in its distribution."""

    u: float
    """Its quantile, in [0, 1)."""
    z: float | None = None
    """A normal draw's standard score (None for other draws)."""

    def score(self) -> float:
        """The standard normal deviate of this quantile."""
        return self.z if self.z is not None else _NORMAL.inv_cdf(min(max(self.u, _TINY), _TOP))


class Place(NamedTuple):
    """Where in a session a draw is asked for: what keys a fresh draw."""

    cycle: int
    behavior: str
    call: int
    """How many draws the behavior made before this one in the cycle."""


class FreshQuantiles:
    """The fresh quantiles of one log's places, keyed by ``key`` (its first 64 bytes, hashed
    once): a place's seed is the 8-byte BLAKE2b digest, keyed so, of ``cycle``,
    ``behavior`` and ``call`` as text, each ended by a NUL but the last."""

    __slots__ = ("_keyed",)

    def __init__(self, key: bytes) -> None:
        self._keyed = hashlib.blake2b(key=key[:64], digest_size=8)

    def seed(self, place: Place) -> bytes:
        """Eight bytes for ``place``."""
        hasher = self._keyed.copy()
        hasher.update(f"{place.cycle}\x00{place.behavior}\x00{place.call}".encode())
        return hasher.digest()

    def quantile(self, place: Place) -> Quantile:
        """The quantile of a draw the recording does not have, at ``place``: its seed as a
        float in [0, 1), 53 bits, as generators make them."""
        return Quantile((int.from_bytes(self.seed(place), "little") >> 11) * _TINY)


def _clamped(u: float) -> float:
    return u if 0.0 <= u < 1.0 else (0.5 if math.isnan(u) else min(max(u, 0.0), _TOP))


def scalar_quantile(kind: str, value: Any, params: tuple[Any, ...]) -> Quantile | None:
    """The quantile of a recorded scalar draw; None where it cannot be known (a format-1
    draw, which recorded no request, or an array)."""
    if kind not in _SCALARS or (kind != "random" and not params):
        return None
    if kind == "random":
        return Quantile(_clamped(value))
    if kind == "uniform":
        a, b = params
        return Quantile(_clamped((value - a) / (b - a)) if b != a else 0.5)
    if kind == "gauss":
        mu, sigma = params
        z = (value - mu) / sigma if sigma else 0.0
        u = 0.5 * (1.0 + math.erf(z / _SQRT2))  # NormalDist().cdf(z), bit for bit
        return Quantile(_clamped(u) if math.isfinite(z) else 0.5, z)
    low, count = (params[0], params[1] - params[0] + 1) if kind == "randint" else (0, params[0])
    return Quantile(_clamped((value - low + 0.5) / count) if count > 0 else 0.5)


def scalar_value(kind: str, params: tuple[Any, ...], quantile: Quantile) -> Any:
    """The value of the request ``kind(*params)`` at ``quantile``.

    :raises ValueError: the request has no values (``randint(5, 3)``, a choice of none),
        as the recording's generator would.
    """
    if kind == "random":
        return quantile.u
    if kind == "uniform":
        a, b = params
        return a + (b - a) * quantile.u
    if kind == "gauss":
        mu, sigma = params
        return mu + sigma * quantile.score()
    low, count = (params[0], params[1] - params[0] + 1) if kind == "randint" else (0, params[0])
    if count < 1:
        raise ValueError(f"{kind}{tuple(params)!r} has no values to draw from")
    return int(low + min(int(quantile.u * count), count - 1))


def array_value(
    kind: str,
    params: tuple[Any, ...],
    recorded: tuple[str, tuple[Any, ...], npt.NDArray[Any]] | None,
    seed: bytes,
) -> npt.NDArray[Any]:
    """The array asked for as ``kind(*params)`` (``low``, ``high``, ``shape``), with the
    quantiles of the ``recorded`` array of the same kind (its kind, parameters and value)
    element by element where it has one, and fresh ones from ``seed`` for the rest."""
    import numpy as np  # noqa: PLC0415 - array draws need numpy

    low, high, shape = params
    size = math.prod(shape)
    generator = np.random.Generator(np.random.PCG64(int.from_bytes(seed, "little")))
    if kind == "normal_array":
        scores = generator.standard_normal(size)
        if recorded is not None:
            (loc, scale, _), old = recorded[1], recorded[2].ravel()
            kept = min(size, old.size)
            scores[:kept] = (old[:kept] - loc) / scale if scale else 0.0
        return np.asarray(low + high * scores, dtype="<f8").reshape(shape)
    quantiles = generator.random(size)
    if recorded is not None:
        (a, b, _), old = recorded[1], recorded[2].ravel()
        kept = min(size, old.size)
        if kind == "uniform_array":
            quantiles[:kept] = (old[:kept] - a) / (b - a) if b != a else 0.5
        else:
            quantiles[:kept] = (old[:kept] - a + 0.5) / (b - a) if b > a else 0.5
        quantiles = np.clip(np.nan_to_num(quantiles, nan=0.5), 0.0, _TOP)
    if kind == "uniform_array":
        return np.asarray(low + (high - low) * quantiles, dtype="<f8").reshape(shape)
    count = int(high) - int(low)
    if count < 1:
        raise ValueError(f"integers_array({low!r}, {high!r}) has no values to draw from")
    picked = np.minimum((quantiles * count).astype("<i8"), count - 1)
    return np.asarray(int(low) + picked, dtype="<i8").reshape(shape)
