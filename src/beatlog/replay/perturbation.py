"""The perturbations of a variant of a recording (:class:`Perturbations`), each value
from numbers keyed by the log, the variant's number and the cycle, never the wall clock
or a global generator: the same log, code and number give the same bytes on every run
and machine. The records are rewritten before the replay core reads them and the noise
is added through its ``perturb`` hook, so a replay that is no variant pays nothing.
"""

from __future__ import annotations

import hashlib
import math
import struct
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgspec

from beatlog.errors import CorruptLogError, FieldError, SpecError
from beatlog.log.format import DECODE_ERRORS, EMPTY_LIST, CycleRecord, SessionHeader
from beatlog.project.config import VariantsConfig
from beatlog.replay.draws import log_key
from beatlog.replay.fit.check import check_state_fields
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.fit.schema import field_schema
from beatlog.replay.view import full_state

if TYPE_CHECKING:
    from beatlog.replay.core import Replayer

__all__ = ["Perturbations", "Perturber", "Variant", "declared", "variant_key"]

_NS = 1_000_000_000
_SPAN = 2.0**32
"""How many values a keyed number takes (32 bits)."""
_GROUP = 64
"""Cycles whose numbers of one kind come from one hash call."""
_HALF_TINY = 2.0**-31
"""A keyed number times this, less 1, is in [-1, 1)."""
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
    """The +- bound on the uniform offset added to each numeric robot-state field named
    (dotted paths for fields of nested structs; an integer field's offset rounded)."""
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
    (:func:`~beatlog.replay.draws.log_key`): 32 bytes of BLAKE2b."""
    return hashlib.blake2b(b"variant\x00%d" % number, key=key[:64], digest_size=32).digest()


def _block(key: bytes, kind: bytes, at: int, count: int) -> tuple[int, ...]:
    """The first ``count`` uniform numbers of ``kind`` (as 32-bit integers) at ``at``, a
    group of :data:`_GROUP` cycles or one cycle: the SHAKE128 output of the variant's
    ``key``, the kind and ``at``. Each kind its own stream, so that one perturbation left
    out leaves the others' numbers as they were, and no state carried from group to
    group, so that a cycle's numbers are the same whatever window is replayed."""
    digest = hashlib.shake_128(b"%s%s\x00%d" % (key, kind, at)).digest(4 * count)
    return struct.unpack(f"<{count}I", digest)


def _span(key: bytes, kind: bytes, first: int, count: int) -> list[int]:
    """One number of ``kind`` for each of the ``count`` cycles from ``first``."""
    numbers: list[int] = []
    end = first + count
    for group in range(first // _GROUP, (end + _GROUP - 1) // _GROUP):
        start = group * _GROUP
        block = _block(key, kind, group, min(end, start + _GROUP) - start)
        numbers.extend(block[max(first, start) - start :])
    return numbers


class Perturber:
    """The perturbations of one variant of one log: its records rewritten, its robot
    states made noisy, each from the variant's keyed numbers of the batch."""

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
        self._key = variant_key(log_key(header), variant.number)
        self._jitter_ns = round(perturbations.heartbeat_jitter * _NS)
        self._draws = perturbations.draws
        sensing = replayer.perception is not None
        self._drop = perturbations.drop_samples * _SPAN if sensing else 0.0
        self._delay = perturbations.delay_samples * _SPAN if sensing else 0.0
        _check_noise(header, perturbations.noise, where, migration)
        self._noise = tuple((name, tuple(name.split("."))) for name in perturbations.noise)
        self._bounds = tuple(perturbations.noise.values())
        self._offsets: list[float] = []
        """The noise's offsets for the batch being replayed, field by field, cycle by
        cycle from :attr:`_first`."""
        self._first = 0
        self._where = where
        self._log = replayer.path
        self._context = replayer.executor.context
        if self._noise:
            replayer.perturb = self.noisy

    def records(
        self, batches: Iterator[Sequence[CycleRecord]], first: int
    ) -> Iterator[Sequence[CycleRecord]]:
        """``batches`` with each record perturbed in place (the session's reader decoded
        them for this replay alone), cycle ``first`` the first; none before the window.
        Each batch's noise is drawn with it, for :meth:`noisy`."""
        cycle = first
        late: list[msgspec.Raw] = []
        jitter_ns = self._jitter_ns
        resampling = self._drop or self._delay
        key = self._key
        fields = len(self._noise)
        for batch in batches:
            size = len(batch)
            skip = min(size, max(0, self._start - cycle))
            perturbed = batch[skip:] if skip else batch
            if perturbed:
                if fields:
                    self._first = cycle
                    # each field its own stream: one left out leaves the others' noise
                    streams = [
                        _span(key, b"noise " + name.encode(), cycle, size)
                        for name, _ in self._noise
                    ]
                    self._offsets = [
                        (u * _HALF_TINY - 1.0) * bound
                        for row in zip(*streams, strict=True)
                        for u, bound in zip(row, self._bounds, strict=True)
                    ]
                if jitter_ns:
                    beats = _span(key, b"heartbeat", cycle, size)
                    for record, u in zip(perturbed, beats[skip:], strict=True):
                        offset = round((u * _HALF_TINY - 1.0) * jitter_ns)
                        record.heartbeat_ns = max(1, record.heartbeat_ns + offset)
                if self._draws:
                    for record in perturbed:
                        record.random_numbers = EMPTY_LIST
                if resampling:
                    self._resample(batch, skip, cycle, late)
            cycle += size
            yield batch

    def _resample(
        self, batch: Sequence[CycleRecord], skip: int, first: int, late: list[msgspec.Raw]
    ) -> None:
        """Each record's samples from the ``skip``-th on (the batch's first is cycle
        ``first``): those delayed into it first, less those dropped or delayed out of
        it (kept in ``late``). Two numbers a sample, each cycle's own."""
        decoded: list[list[msgspec.Raw]] = []
        for cycle, record in enumerate(batch, first):
            try:
                decoded.append(_SAMPLES(record.samples))
            except DECODE_ERRORS as exc:
                raise CorruptLogError(
                    self._log, f"damaged samples in cycle {cycle}: {exc}"
                ) from None
        drop, delay = self._drop, self._delay
        for index, samples in enumerate(decoded):
            if index < skip:
                continue  # before the window: as recorded
            numbers = _block(self._key, b"samples", first + index, 2 * len(samples))
            drops, delays = numbers[::2], numbers[1::2]
            if not (late or min(drops, default=_SPAN) < drop or min(delays, default=_SPAN) < delay):
                continue  # none late, dropped or delayed: as recorded
            kept = late[:]
            late.clear()
            for sample, dropped, delayed in zip(samples, drops, delays, strict=True):
                if dropped >= drop:
                    (late if delayed < delay else kept).append(sample)
            batch[index].samples = msgspec.Raw(msgspec.msgpack.encode(kept))

    def noisy(self, state: Any) -> Any:
        """RS_t with each field named offset within its bound (the replay core's
        ``perturb`` hook), by the numbers :meth:`records` drew for the cycle's batch;
        before the window, RS_t as recorded."""
        cycle = self._context.cycle + 1
        if cycle < self._start:
            return state
        noise = self._noise
        at = (cycle - self._first) * len(noise)
        state = full_state(state)  # a view of a format-3 batch made whole
        moved: dict[str, Any] = {}
        for (name, path), offset in zip(noise, self._offsets[at : at + len(noise)], strict=True):
            top = path[0]
            value = moved[top] if top in moved else getattr(state, top)
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
    for name in (n for n in names if "." in n):
        try:
            found = field_schema(header.robot_state_schema, migration.recorded_name(name))
        except (RecursionError, TypeError, KeyError, AttributeError):
            found = None
        if found is None:
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
