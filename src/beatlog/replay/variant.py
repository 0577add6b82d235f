"""Variants of a recording: the log replayed with deterministic perturbations
(:class:`~beatlog.replay.perturbation.Perturbations`: fresh random draws, robot-state
noise, heartbeat jitter, samples dropped or delayed), each value from numbers keyed by
the log, the variant's number and the cycle's batch. A variant is judged by the behaviors
not raising and by the invariants, never by equality with the recording: it replays
every cycle, up to the first where behavior code raises or an invariant does not hold.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from beatlog.log.format import CycleRecord, LoggedStateChange
from beatlog.log.reader import SessionLogReader
from beatlog.log.recording import LogSource
from beatlog.model.behavior import System
from beatlog.model.invariant import Invariant
from beatlog.model.perception import Perception
from beatlog.project.usercode import user_traceback
from beatlog.replay.compare import state_fields
from beatlog.replay.core import CycleOutcome, Replayer
from beatlog.replay.draws import log_key
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.invariants import InvariantChecker
from beatlog.replay.outcome import random_draws
from beatlog.replay.perturbation import Perturber, Variant, variant_key
from beatlog.replay.session import Observer, ReplaySession
from beatlog.replay.verdict import Checked, Divergence, ReplayResult
from beatlog.replay.window import Window

__all__ = ["replay_variant"]


class _Ended:
    """What follows a variant's replay past the cycle that fails it: nothing (the log is
    read on, to its end, for damage)."""

    replaying = reading = False

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        """Nothing to take."""


class _InWindow:
    """An observer of a variant's replay that takes its window's cycles alone."""

    def __init__(self, observer: Observer, start: int) -> None:
        self._observer = observer
        self._start = start

    @property
    def replaying(self) -> bool:
        return self._observer.replaying

    @property
    def reading(self) -> bool:
        return self._observer.reading

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        if outcome is None or outcome.cycle >= self._start:
            self._observer.add(record, outcome)


class _VariantJudge:
    """Judges a variant's cycles for a replay session: every cycle replayed, its
    records perturbed, until behavior code raises or an invariant does not hold; the
    cycles before the ``window`` must only not raise, and none after it is read."""

    def __init__(
        self,
        replayer: Replayer,
        perturber: Perturber,
        invariants: InvariantChecker | None,
        window: Window,
    ) -> None:
        self._replayer = replayer
        self._perturber = perturber
        self._invariants = invariants
        self._window = window
        self.divergence: Divergence | None = None
        self.changes = self.outputs = self.draws = 0
        """What the behaviors did in the window's cycles that went cleanly."""

    def batches(self, batches: Iterator[Sequence[CycleRecord]]) -> Iterator[Sequence[CycleRecord]]:
        """The log's batches up to the window's end, perturbed."""
        first = self._replayer.executor.context.cycle + 1
        batches = self._window.batches(batches, self._replayer)
        return self._perturber.records(batches, first)

    def judge(
        self,
        index: int,
        record: CycleRecord,
        changes: list[LoggedStateChange] | None,
        outcome: CycleOutcome | None,
    ) -> Observer | None:
        """Judge the cycle replayed last: its behaviors raised, or an invariant does not
        hold in it; else count what it did. Before the window only raising fails."""
        replayer = self._replayer
        context = replayer.executor.context
        if changes is None and replayer.raised is not None:
            self.divergence = self._raised(outcome or replayer.outcome())
            return _Ended()
        if context.cycle < self._window.start:
            return None
        stepped = replayer.stepped  # a cycle that drew otherwise than recorded counts too
        if stepped is not None:
            self.changes += len(stepped)
            self.outputs += len(context.outputs)
            self.draws += len(replayer.random.drawn)
        if self._invariants is not None:
            self.divergence = self._invariants.check(outcome or replayer.outcome())
        return None if self.divergence is None else _Ended()

    def _raised(self, outcome: CycleOutcome) -> Divergence:
        """The divergence of a cycle whose behavior code (or perception) raised."""
        replayer = self._replayer
        stop = replayer.stop(outcome)
        assert stop is not None  # it raised
        failure = outcome.perception_failure or outcome.failure  # as stop() headlines them
        assert failure is not None
        names = replayer.executor.behavior_ids
        start = self._window.start
        before = f"before the window (cycle {start} on): " if outcome.cycle < start else ""
        return Divergence(
            kind=stop.kind,
            cycle=outcome.cycle,
            time_ns=outcome.time_ns,
            message=before + stop.message,
            behavior=stop.behavior,
            robot_state=state_fields(outcome.state),
            random_drawn=tuple(random_draws(outcome.drawn, names)),
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
    :func:`~beatlog.replay.judge.replay`: the cycles before it replay as recorded,
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
    window = Window(start_cycle, end_cycle, fresh=fresh_start)
    started = time.perf_counter()
    with ReplaySession(
        log,
        system,
        perception=perception,
        migration=migration,
        match_draws=True,
        fresh_from=window.fresh_from,
    ) as session:
        reader = session.reader
        replayer = session.replayer
        assert replayer is not None  # a session with a system replays
        replayer.random.match_draws(variant_key(log_key(reader.header), variant.number))
        perturber = Perturber(
            variant,
            reader.header,
            replayer,
            where or reader.path,
            migration,
            start_cycle=start_cycle,
        )
        checker = InvariantChecker(invariants, system) if invariants else None
        judge = _VariantJudge(replayer, perturber, checker, window)
        session.run([_InWindow(factory(reader), start_cycle) for factory in observers], judge=judge)
        context = replayer.executor.context
        status = None if window.closed else reader.status
        divergence = judge.divergence
        where = where or reader.path
        if divergence is None:
            divergence = window.log_ended(
                status, where, context.cycle + 1, context.time_ns, allow_truncated=allow_truncated
            )
        wall = time.perf_counter() - started
    return ReplayResult(
        log=Path(log),
        ok=divergence is None,
        cycles=max(0, context.cycle + 1 - start_cycle),
        checked=Checked(judge.changes, judge.outputs, judge.draws, replayer.samples_perceived),
        robot_time_ns=max(0, context.time_ns - window.start_ns),
        wall_time_s=wall,
        status=status,
        divergence=divergence,
        divergent_cycles=0 if divergence is None else 1,
        reproduce=reproduce,
    )
