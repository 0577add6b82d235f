"""Variants of a recording: the log replayed with deterministic perturbations, judged by
the behaviors not raising and by the observers that judge (the invariants), never by
equality with the recording.

Variant n of a log perturbs what the behaviors get, each value from a generator keyed by
the log (:func:`~beatlog.replaying.draws.log_key`), n and the cycle (the keyed source of
:mod:`beatlog.model.luck`), never the wall clock or a global generator: the same log,
code and n give the same bytes on every run and machine. What it perturbs
(:class:`Perturbations`):

- random draws: every draw is fresh, keyed by (log, n) and its place, instead of the
  recorded one;
- robot-state noise: each field named (a dotted path for a field of a nested struct) gets
  a uniform offset within its +- bound; an integer field a rounded one;
- heartbeat jitter: each HB_t moves by a uniform offset within the bound, and stays at
  least 1 ns;
- for sensor-level replay (a perception step, a log recorded with samples): each sample
  is dropped, or delayed to the next cycle, with the share given.

The replay core stays as it is: the records are rewritten before it reads them, the
noise is added through its ``observe`` hook, and the draws come from its living random
source keyed by the variant; a replay that is no variant pays nothing.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import msgspec

from beatlog.errors import CorruptLogError, FieldError
from beatlog.log.format import (
    DECODE_ERRORS,
    EMPTY_LIST,
    CycleRecord,
    SessionHeader,
    StateChangeRecord,
)
from beatlog.log.reader import SessionLogReader
from beatlog.log.recording import LogSource
from beatlog.model.behavior import System
from beatlog.model.perception import Perception
from beatlog.project.usercode import user_traceback
from beatlog.replaying.compare import state_fields
from beatlog.replaying.core import CycleOutcome, Replayer
from beatlog.replaying.draws import log_key
from beatlog.replaying.fit.check import check_state_fields
from beatlog.replaying.fit.migration import StateMigration
from beatlog.replaying.session import Observer, ReplaySession
from beatlog.replaying.verdict import (
    Checked,
    Divergence,
    DivergenceKind,
    DrawReport,
    ReplayResult,
)
from beatlog.replaying.view import full_state

__all__ = ["Judging", "Perturbations", "Variant", "replay_variant", "variant_key"]

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


@runtime_checkable
class Judging(Observer, Protocol):
    """An observer that judges a variant (the invariants): the first cycle where it
    reports a divergence ends the variant, failed."""

    @property
    def divergence(self) -> Divergence | None:
        """What it found wrong, once it found it."""


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


class _Perturber:
    """The perturbations of one variant of one log: its records rewritten, its robot
    states made noisy, each from the variant's keyed numbers of the cycle."""

    def __init__(
        self,
        variant: Variant,
        header: SessionHeader,
        replayer: Replayer,
        where: Path,
        migration: StateMigration,
    ) -> None:
        perturbations = variant.perturbations
        self._uniforms = _Uniforms(variant_key(log_key(header), variant.number))
        self._jitter_ns = round(perturbations.heartbeat_jitter * _NS)
        self._draws = perturbations.draws
        sensing = replayer.perception is not None
        self._drop = perturbations.drop_samples if sensing else 0.0
        self._delay = perturbations.delay_samples if sensing else 0.0
        check_state_fields(header, perturbations.noise, where, "noise bound for", migration)
        self._noise = tuple(
            (name, tuple(name.split(".")), bound) for name, bound in perturbations.noise.items()
        )
        self._where = where
        self._log = replayer.path
        self._context = replayer.executor.context
        if self._noise:
            replayer.observe = self.noisy

    @property
    def rewrites(self) -> bool:
        """Whether the records are rewritten at all."""
        return bool(self._jitter_ns or self._draws or self._drop or self._delay)

    def records(
        self, batches: Iterator[Sequence[CycleRecord]], first: int
    ) -> Iterator[Sequence[CycleRecord]]:
        """``batches`` with each record perturbed in place (the session's reader decoded
        them for this replay alone), cycle ``first`` the first."""
        cycle = first
        late: list[msgspec.Raw] = []
        jitter_ns = self._jitter_ns
        resampling = self._drop or self._delay
        for batch in batches:
            for record in batch:
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
        ``observe`` hook)."""
        noise = self._noise
        uniforms = self._uniforms.draw(self._context.cycle + 1, "noise", len(noise))
        state = full_state(state)
        moved: dict[str, Any] = {}
        for (name, path, bound), u in zip(noise, uniforms, strict=False):
            top = path[0]
            value = moved[top] if top in moved else getattr(state, top)
            moved[top] = self._offset(value, path[1:], name, (2 * u - 1) * bound)
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


class _Ended:
    """What follows a variant's replay past its end: nothing (the log is read on, to
    its end, for damage)."""

    replaying = reading = False

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        """Nothing to take."""


class _WhileJudged:
    """An observer of a variant's replay for as long as the variant is judged: the
    cycles up to the one that fails it, that one included."""

    def __init__(self, observer: Observer, judge: _VariantJudge) -> None:
        self._observer = observer
        self._judge = judge

    @property
    def replaying(self) -> bool:
        return self._judge.divergence is None and self._observer.replaying

    @property
    def reading(self) -> bool:
        return self._judge.divergence is None and self._observer.reading

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        self._observer.add(record, outcome)


class _VariantJudge:
    """Judges a variant's cycles for a replay session: every cycle replayed, its
    records perturbed, until behavior code raises or an observer that judges reports
    a divergence."""

    def __init__(
        self,
        replayer: Replayer,
        perturber: _Perturber,
        judging: Sequence[Judging],
    ) -> None:
        self._replayer = replayer
        self._perturber = perturber
        self._judging = judging
        self._first = replayer.executor.context.cycle + 1
        self.divergence: Divergence | None = None
        self.changes = self.outputs = self.draws = 0
        """What the behaviors did in the cycles that went cleanly."""

    def batches(self, batches: Iterator[Sequence[CycleRecord]]) -> Iterator[Sequence[CycleRecord]]:
        """The log's batches, perturbed."""
        if not self._perturber.rewrites:
            return batches
        return self._perturber.records(batches, self._first)

    def judge(
        self,
        index: int,
        record: CycleRecord,
        changes: list[StateChangeRecord] | None,
        outcome: CycleOutcome | None,
    ) -> Observer | None:
        """Judge the cycle replayed last: its behaviors raised, or an observer that judges
        found it wrong; else count what it did."""
        replayer = self._replayer
        if changes is not None:
            self.changes += len(changes)
            self.outputs += len(replayer.executor.context.outputs)
            self.draws += len(replayer.random.drawn)
        elif replayer.raised is not None:
            self.divergence = self._raised(outcome or replayer.outcome())
            return _Ended()
        for observer in self._judging:
            found = observer.divergence
            if found is not None:
                self.divergence = found
                return _Ended()
        return None

    def _raised(self, outcome: CycleOutcome) -> Divergence:
        """The divergence of a cycle whose behavior code (or perception) raised."""
        replayer = self._replayer
        stop = replayer.stop(outcome)
        assert stop is not None  # it raised
        failure = outcome.failure or outcome.perception_failure
        assert failure is not None
        names = replayer.executor.behavior_ids
        return Divergence(
            kind=stop.kind,
            cycle=outcome.cycle,
            time_ns=outcome.time_ns,
            message=stop.message,
            behavior=stop.behavior,
            robot_state=state_fields(outcome.state),
            random_drawn=tuple(
                DrawReport(
                    names[d.actor] if 0 <= d.actor < len(names) else "system",
                    d.kind,
                    d.value,
                    d.call(),
                )
                for d in outcome.drawn
            ),
            traceback=user_traceback(failure),
        )


def replay_variant(
    log: LogSource,
    system: System,
    variant: Variant,
    *,
    perception: Perception | None = None,
    migration: StateMigration | None = None,
    allow_truncated: bool = False,
    observers: Sequence[Callable[[SessionLogReader], Observer]] = (),
    where: Path | None = None,
    reproduce: str = "",
) -> ReplayResult:
    """Replay ``variant`` of ``log`` against ``system``: every cycle, perturbed, until
    behavior code (or ``perception``) raises or an observer that judges
    (:class:`Judging`, built like the rest of ``observers`` from the opened log)
    reports a divergence, which becomes the result's. A variant is never compared with
    the recording. A log cut short fails as a replay does unless ``allow_truncated``.
    ``where`` (the spec, by default the log) is what a noise bound naming no numeric
    field of the recorded robot state is blamed on; ``reproduce`` is the command the
    result gives (a suite's: ``beatlog test`` with the variant's spec).

    :raises beatlog.errors.LogError: the log is missing, damaged or does not fit.
    :raises beatlog.errors.FieldError: a noise bound names no field of the recorded robot
        state, or one that holds no number.
    """
    migration = migration or StateMigration()
    started = time.perf_counter()
    with ReplaySession(
        log, system, perception=perception, migration=migration, living=True
    ) as session:
        reader = session.reader
        replayer = session.replayer
        assert replayer is not None  # a session with a system replays
        key = log_key(reader.header)
        replayer.random.live(variant_key(key, variant.number))
        perturber = _Perturber(variant, reader.header, replayer, where or reader.path, migration)
        watching = [factory(reader) for factory in observers]
        judging = [observer for observer in watching if isinstance(observer, Judging)]
        judge = _VariantJudge(replayer, perturber, judging)
        session.run([_WhileJudged(observer, judge) for observer in watching], judge=judge)
        context = replayer.executor.context
        status = reader.status
        divergence = judge.divergence
        if divergence is None and not status.complete and not allow_truncated:
            divergence = Divergence(
                kind=DivergenceKind.LOG_ENDED,
                cycle=context.cycle + 1,
                time_ns=context.time_ns,
                message=f"the log ends early ({status.describe()}); if the session ended "
                "there (a crash), accept what it holds with --allow-truncated "
                "(in a spec: allow_truncated = true)",
            )
        wall = time.perf_counter() - started
    return ReplayResult(
        log=Path(log),
        ok=divergence is None,
        cycles=context.cycle + 1,
        checked=Checked(judge.changes, judge.outputs, judge.draws, replayer.samples_perceived),
        robot_time_ns=context.time_ns,
        wall_time_s=wall,
        status=status,
        divergence=divergence,
        divergent_cycles=0 if divergence is None else 1,
        reproduce=reproduce,
        notes=(),
    )
