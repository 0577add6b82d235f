"""Variants of a recording: the log replayed with deterministic perturbations
(:mod:`beatlog.replaying.perturbation`), judged by the behaviors not raising and by the
invariants, never by equality with the recording.

Variant n of a log perturbs what the behaviors get, each value from numbers keyed by
the log, n and the batch of the log its cycle is in:

- random draws: every draw is fresh, keyed by (log, n) and its place, instead of the
  recorded one;
- robot-state noise: each field named (a dotted path for a field of a nested struct) gets
  a uniform offset within its +- bound; an integer field a rounded one;
- heartbeat jitter: each HB_t moves by a uniform offset within the bound, and stays at
  least 1 ns;
- for sensor-level replay (a perception step, a log recorded with samples): each sample
  is dropped, or delayed to the next cycle, with the share given.

A variant replays every cycle, up to the first where behavior code raises or an
invariant does not hold.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from beatlog.log.format import CycleRecord, StateChangeRecord
from beatlog.log.reader import SessionLogReader
from beatlog.log.recording import LogSource
from beatlog.model.behavior import System
from beatlog.model.invariant import Invariant
from beatlog.model.perception import Perception
from beatlog.project.usercode import user_traceback
from beatlog.replaying.compare import state_fields
from beatlog.replaying.core import CycleOutcome, Replayer
from beatlog.replaying.draws import log_key
from beatlog.replaying.fit.migration import StateMigration
from beatlog.replaying.invariants import InvariantChecker
from beatlog.replaying.outcome import draw_reports
from beatlog.replaying.perturbation import Perturber, Variant, variant_key
from beatlog.replaying.session import Observer, ReplaySession, check_window, through
from beatlog.replaying.verdict import Checked, Divergence, DivergenceKind, ReplayResult

__all__ = ["replay_variant"]


class _Ended:
    """What follows a variant's replay past its end: nothing (the log is read on, to
    its end, for damage)."""

    replaying = reading = False

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        """Nothing to take."""


class _WhileJudged:
    """An observer of a variant's replay for as long as the variant is judged: the
    cycles of its window up to the one that fails it, that one included."""

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
        if outcome is None or outcome.cycle >= self._judge.start_cycle:
            self._observer.add(record, outcome)


class _VariantJudge:
    """Judges a variant's cycles for a replay session: every cycle replayed, its
    records perturbed, until behavior code raises or an invariant does not hold; in a
    window from ``start_cycle`` to ``end_cycle``, the cycles before it must only not
    raise, and none after it is read."""

    def __init__(
        self,
        replayer: Replayer,
        perturber: Perturber,
        invariants: InvariantChecker | None,
        *,
        start_cycle: int = 0,
        end_cycle: int | None = None,
    ) -> None:
        self._replayer = replayer
        self._perturber = perturber
        self._invariants = invariants
        self._first = replayer.executor.context.cycle + 1
        self.start_cycle = start_cycle
        self._end = end_cycle
        self.start_ns = 0
        """Robot time where the window starts."""
        self.window_closed = False
        """Whether the log's batches stopped at the window's end, the rest unread."""
        self.divergence: Divergence | None = None
        self.changes = self.outputs = self.draws = 0
        """What the behaviors did in the cycles that went cleanly."""

    def batches(self, batches: Iterator[Sequence[CycleRecord]]) -> Iterator[Sequence[CycleRecord]]:
        """The log's batches up to the window's end, perturbed."""
        if self._end is not None:
            batches = through(batches, self._end, self._close, self._first)
        if not self._perturber.rewrites:
            return batches
        return self._perturber.records(batches, self._first)

    def _close(self) -> None:
        self.window_closed = True

    def judge(
        self,
        index: int,
        record: CycleRecord,
        changes: list[StateChangeRecord] | None,
        outcome: CycleOutcome | None,
    ) -> Observer | None:
        """Judge the cycle replayed last: its behaviors raised, or an invariant does not
        hold in it; else count what it did. Before the window only raising fails."""
        replayer = self._replayer
        context = replayer.executor.context
        before = context.cycle < self.start_cycle
        if context.cycle == self.start_cycle:
            self.start_ns = context.time_ns - context.dt_ns
        if changes is None and replayer.raised is not None:
            self.divergence = self._raised(outcome or replayer.outcome())
            return _Ended()
        stepped = replayer.stepped  # a cycle that drew otherwise than recorded counts too
        if stepped is not None and not before:
            self.changes += len(stepped)
            self.outputs += len(context.outputs)
            self.draws += len(replayer.random.drawn)
        if before:
            return None
        if self._invariants is not None:
            self.divergence = self._invariants.check(outcome or replayer.outcome())
            if self.divergence is not None:
                return _Ended()
        return None

    def _raised(self, outcome: CycleOutcome) -> Divergence:
        """The divergence of a cycle whose behavior code (or perception) raised."""
        replayer = self._replayer
        stop = replayer.stop(outcome)
        assert stop is not None  # it raised
        failure = outcome.perception_failure or outcome.failure  # as stop() headlines them
        assert failure is not None
        names = replayer.executor.behavior_ids
        before = (
            f"before the window (cycle {self.start_cycle} on): "
            if outcome.cycle < self.start_cycle
            else ""
        )
        return Divergence(
            kind=stop.kind,
            cycle=outcome.cycle,
            time_ns=outcome.time_ns,
            message=before + stop.message,
            behavior=stop.behavior,
            robot_state=state_fields(outcome.state),
            random_drawn=tuple(draw_reports(outcome.drawn, names)),
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
    invariants: Sequence[Invariant | type | str] = (),
    observers: Sequence[Callable[[SessionLogReader], Observer]] = (),
    where: Path | None = None,
    reproduce: str = "",
    start_cycle: int = 0,
    end_cycle: int | None = None,
    fresh_start: bool = False,
) -> ReplayResult:
    """Replay ``variant`` of ``log`` against ``system``: every cycle, perturbed, until
    behavior code (or ``perception``) raises or one of ``invariants`` (as
    :func:`~beatlog.replay` takes them) does not hold, which becomes the result's
    divergence. A variant is never compared with the recording. ``observers``, built
    from the opened log, take the cycles up to the one that fails it, that one included.
    A log cut short fails as a replay does unless ``allow_truncated``.
    ``where`` (the spec, by default the log) is what a noise bound naming no numeric
    field of the recorded robot state is blamed on; ``reproduce`` is the command the
    result gives (a suite's: ``beatlog test`` with the variant's spec).

    ``start_cycle`` and ``end_cycle`` narrow it to a window, as they do
    :func:`~beatlog.replaying.judge.replay`: the cycles before it replay as recorded,
    unperturbed and unjudged but for raising, and replay stops after its end; with
    ``fresh_start``, the behaviors start from rest at ``start_cycle`` and the cycles
    before it are not replayed.

    :raises beatlog.errors.LogError: the log is missing, damaged or does not fit.
    :raises beatlog.errors.FieldError: a noise bound names no field of the recorded robot
        state, or one that holds no number.
    :raises beatlog.errors.SystemLoadError: an invariant named does not import.
    :raises beatlog.errors.WindowError: the window starts or ends past the log's last
        cycle.
    """
    migration = migration or StateMigration()
    started = time.perf_counter()
    with ReplaySession(
        log,
        system,
        perception=perception,
        migration=migration,
        living=True,
        fresh_from=start_cycle if fresh_start else 0,
    ) as session:
        reader = session.reader
        replayer = session.replayer
        assert replayer is not None  # a session with a system replays
        key = log_key(reader.header)
        replayer.random.live(variant_key(key, variant.number))
        perturber = Perturber(
            variant,
            reader.header,
            replayer,
            where or reader.path,
            migration,
            start_cycle=start_cycle,
        )
        checker = InvariantChecker(invariants, system) if invariants else None
        judge = _VariantJudge(
            replayer, perturber, checker, start_cycle=start_cycle, end_cycle=end_cycle
        )
        watching = [_WhileJudged(factory(reader), judge) for factory in observers]
        session.run(watching, judge=judge)
        context = replayer.executor.context
        status = None if judge.window_closed else reader.status
        divergence = judge.divergence
        if divergence is None and status is not None and status.complete:
            check_window(where or reader.path, status.cycles, start_cycle, end_cycle)
        if (
            divergence is None
            and status is not None
            and not status.complete
            and not allow_truncated
        ):
            divergence = Divergence(
                kind=DivergenceKind.LOG_ENDED,
                cycle=min(context.cycle + 1, status.cycles),
                time_ns=context.time_ns,
                message=f"the log ends early ({status.describe()}); if the session ended "
                "there (a crash), accept what it holds with --allow-truncated "
                "(in a spec: allow_truncated = true)",
            )
        wall = time.perf_counter() - started
    return ReplayResult(
        log=Path(log),
        ok=divergence is None,
        cycles=max(0, context.cycle + 1 - start_cycle),
        checked=Checked(judge.changes, judge.outputs, judge.draws, replayer.samples_perceived),
        robot_time_ns=max(0, context.time_ns - judge.start_ns),
        wall_time_s=wall,
        status=status,
        divergence=divergence,
        divergent_cycles=0 if divergence is None else 1,
        reproduce=reproduce,
        notes=(),
    )
