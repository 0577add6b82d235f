"""The perturbations of a variant of a recording, and how they are made: each value from
numbers keyed by the log (:func:`~beatlog.replaying.draws.log_key`), the variant's
number and the cycle, never the wall clock or a global generator, so that the same log,
code and number give the same bytes on every run and machine (:class:`Perturbations`
says what is perturbed). The records are rewritten before the replay core reads them
and the noise is added through its ``perturb`` hook: a replay that is no variant pays
nothing. :mod:`beatlog.replaying.variant` replays and judges a variant.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgspec

from beatlog.errors import CorruptLogError, FieldError, SpecError
from beatlog.log.format import DECODE_ERRORS, EMPTY_LIST, CycleRecord, SessionHeader
from beatlog.project.config import VariantsConfig
from beatlog.replaying.draws import log_key
from beatlog.replaying.fit.check import check_state_fields
from beatlog.replaying.fit.migration import StateMigration
from beatlog.replaying.fit.schema import field_schema
from beatlog.replaying.view import full_state

if TYPE_CHECKING:
    from beatlog.replaying.core import Replayer

__all__ = ["Perturbations", "Perturber", "Variant", "declared", "variant_key"]

_NS = 1_000_000_000
_TINY = 2.0**-32
_MASK = (1 << 64) - 1
_GOLDEN = 0x9E3779B97F4A7C15
"""SplitMix64's increment."""
_INDEX_BITS = 20
"""Room for the numbers of one kind in one cycle: a million."""
_SAMPLES = msgspec.msgpack.Decoder(list[msgspec.Raw]).decode
"""A cycle's samples, each as its bytes."""


@dataclass(frozen=True)
class Perturbations:
    """What a variant perturbs, and within which bounds (a spec's ``[variants]``)."""

    draws: bool = True
    """Draw every random number fresh, keyed by the log and the variant's number."""
    heartbeat_jitter: float = 0.0
    """The +- bound, in seconds, on the offset added to each HB_t (which stays >= 1 ns)."""
    noise: Mapping[str, float] = field(default_factory=dict)
    """The +- bound on the offset added to each numeric robot-state field named (dotted
    paths for fields of nested structs)."""
    drop_samples: float = 0.0
    """Sensor-level replay: the share of samples dropped."""
    delay_samples: float = 0.0
    """Sensor-level replay: the share of samples delayed by one cycle."""


@dataclass(frozen=True)
class Variant:
    """Variant ``number`` (from 1) of a recording, with its ``perturbations``."""

    number: int
    perturbations: Perturbations


def variant_key(key: bytes, number: int) -> bytes:
    """What keys every perturbation of variant ``number`` of the log keyed by ``key``
    (:func:`~beatlog.replaying.draws.log_key`): 32 bytes of BLAKE2b."""
    return hashlib.blake2b(b"variant\x00%d" % number, key=key[:64], digest_size=32).digest()


class _Uniforms:
    """Uniform numbers in [0, 1) keyed by a variant, SplitMix64's: the ``i``-th pair of
    one kind in one cycle (from 0) are the two halves, 32 bits each, of the
    ``(cycle << 20) + i + 1``-th SplitMix64 output of a stream seeded by the BLAKE2b
    digest (8 bytes) of the kind, keyed by the variant.
    Each kind is its own stream, so that one perturbation left out leaves the others'
    numbers as they were, and any cycle's numbers are had at once (no state carried
    from cycle to cycle, no global generator): plain integer arithmetic, the same on
    every machine."""

    __slots__ = ("_key", "_seeds")

    def __init__(self, key: bytes) -> None:
        self._key = key[:64]
        self._seeds: dict[str, int] = {}

    def _seed(self, kind: str) -> int:
        seed = int.from_bytes(
            hashlib.blake2b(kind.encode(), key=self._key, digest_size=8).digest(), "little"
        )
        self._seeds[kind] = seed
        return seed

    def draw(self, cycle: int, kind: str, count: int) -> list[float]:
        """``count`` numbers of ``kind`` in ``cycle`` (one more where ``count`` is odd):
        two of 32 bits from each output."""
        seed = self._seeds.get(kind)
        if seed is None:
            seed = self._seed(kind)
        state = seed + (cycle << _INDEX_BITS) * _GOLDEN
        numbers: list[float] = []
        for _ in range(0, count, 2):
            state += _GOLDEN
            x = state & _MASK
            x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & _MASK
            x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & _MASK
            x ^= x >> 31
            numbers += ((x >> 32) * _TINY, (x & 0xFFFFFFFF) * _TINY)
        return numbers


class Perturber:
    """The perturbations of one variant of one log: its records rewritten, its robot
    states made noisy, each from the variant's keyed numbers of the cycle."""

    def __init__(
        self,
        variant: Variant,
        header: SessionHeader,
        replayer: Replayer,
        where: Path,
        migration: StateMigration,
        *,
        start_cycle: int = 0,
    ) -> None:
        perturbations = variant.perturbations
        self._start = start_cycle
        """The first cycle perturbed (a window's start): those before replay as recorded."""
        self._uniforms = _Uniforms(variant_key(log_key(header), variant.number))
        self._jitter_ns = round(perturbations.heartbeat_jitter * _NS)
        self._draws = perturbations.draws
        sensing = replayer.perception is not None
        self._drop = perturbations.drop_samples if sensing else 0.0
        self._delay = perturbations.delay_samples if sensing else 0.0
        _check_noise(header, perturbations.noise, where, migration)
        self._noise = tuple(
            (name, tuple(name.split(".")), bound) for name, bound in perturbations.noise.items()
        )
        self._where = where
        self._log = replayer.path
        self._context = replayer.executor.context
        self._robot_state = replayer.system.robot_state
        if self._noise:
            replayer.perturb = self.noisy

    @property
    def rewrites(self) -> bool:
        """Whether the records are rewritten at all."""
        return bool(self._jitter_ns or self._draws or self._drop or self._delay)

    def records(
        self, batches: Iterator[Sequence[CycleRecord]], first: int
    ) -> Iterator[Sequence[CycleRecord]]:
        """``batches`` with each record perturbed in place (the session's reader decoded
        them for this replay alone), cycle ``first`` the first; none before the window."""
        cycle = first
        late: list[msgspec.Raw] = []
        jitter_ns = self._jitter_ns
        resampling = self._drop or self._delay
        for batch in batches:
            for record in batch:
                if cycle < self._start:
                    cycle += 1
                    continue
                if jitter_ns:
                    (u,) = self._uniforms.draw(cycle, "heartbeat", 1)[:1]
                    offset = round((2 * u - 1) * jitter_ns)
                    record.heartbeat_ns = max(1, record.heartbeat_ns + offset)
                if self._draws:
                    record.random_numbers = EMPTY_LIST
                if resampling:
                    record.samples = self._samples(record, cycle, late)
                cycle += 1
            yield batch

    def _samples(self, record: CycleRecord, cycle: int, late: list[msgspec.Raw]) -> msgspec.Raw:
        """The cycle's samples, those delayed into it first, less those dropped or
        delayed out of it (kept in ``late``)."""
        try:
            samples = _SAMPLES(record.samples)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(self._log, f"damaged samples in cycle {cycle}: {exc}") from None
        numbers = self._uniforms.draw(cycle, "samples", 2 * len(samples))
        kept = late[:]
        late.clear()
        for sample, drop, delay in zip(samples, numbers[::2], numbers[1::2], strict=False):
            if drop < self._drop:
                continue
            (late if delay < self._delay else kept).append(sample)
        if kept == samples:
            return record.samples
        return msgspec.Raw(msgspec.msgpack.encode(kept))

    def noisy(self, state: Any) -> Any:
        """RS_t with each field named offset within its bound (the replay core's
        ``perturb`` hook); before the window, RS_t as recorded."""
        noise = self._noise
        cycle = self._context.cycle + 1
        if cycle < self._start:
            return state
        uniforms = self._uniforms.draw(cycle, "noise", len(noise))
        if state.__class__ is not self._robot_state:  # a view of a format-3 batch
            state = full_state(state)
        moved: dict[str, Any] = {}
        for (name, path, bound), u in zip(noise, uniforms, strict=False):
            top = path[0]
            value = moved[top] if top in moved else getattr(state, top)
            offset = (2 * u - 1) * bound
            if value.__class__ is float and len(path) == 1:  # the common case, at once
                moved[top] = value + offset
            else:
                moved[top] = self._offset(value, path[1:], name, offset)
        return msgspec.structs.replace(state, **moved)

    def _offset(self, value: Any, path: tuple[str, ...], name: str, offset: float) -> Any:
        """``value`` with the field at ``path`` in it (``value`` itself, for none) moved
        by ``offset``."""
        if path:
            inner = self._offset(getattr(value, path[0]), path[1:], name, offset)
            return msgspec.structs.replace(value, **{path[0]: inner})
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise FieldError(
                f"{self._where}: noise bound for {name!r}: the field holds "
                f"{type(value).__name__} {value!r}, not a number"
            )
        if isinstance(value, int):
            return value + round(offset)
        return value + offset


def _check_noise(
    header: SessionHeader, names: Iterable[str], where: Path, migration: StateMigration
) -> None:
    """Refuse a noise bound naming no field of the recorded robot state (a dotted name:
    no field of its nested struct), as :func:`check_state_fields` does, naming ``where``.

    :raises beatlog.errors.FieldError: one names no such field.
    """
    names = list(names)
    check_state_fields(
        header, [n for n in names if "." not in n], where, "noise bound for", migration
    )
    for name in names:
        try:
            found = field_schema(header.robot_state_schema, migration.recorded_name(name))
        except (RecursionError, TypeError, KeyError, AttributeError):
            found = None
        if found is None and "." in name:
            raise FieldError(
                f"{where}: noise bound for {name!r}: the recorded robot state "
                f"{header.robot_state_type} has no such field"
            )


def declared(path: Path, tables: Sequence[VariantsConfig]) -> tuple[Perturbations | None, int]:
    """The perturbations ``tables`` (``[variants]`` of the project, then of the spec at
    ``path``) declare, each key on top of the one before (``noise`` field by field), and
    the variants to run; none where there is no table.

    :raises beatlog.errors.SpecError: a bound is not a finite number, 0 or more.
    """
    if not tables:
        return None, 0
    merged: dict[str, Any] = {}
    noise: dict[str, float] = {}
    for table in tables:
        given = msgspec.structs.asdict(table)
        noise.update(given.pop("noise"))
        merged.update((key, value) for key, value in given.items() if value is not None)
    bounds = {f"noise.{name}": bound for name, bound in noise.items()}
    bounds["heartbeat_jitter"] = merged.get("heartbeat_jitter", 0.0)
    for key, bound in bounds.items():
        if not (math.isfinite(bound) and bound >= 0):
            raise SpecError(
                path, f"key 'variants.{key}': expected a finite number >= 0, got {bound}"
            )
    count = merged.pop("count", 0)
    return Perturbations(**merged, noise=noise), count
