"""A replay session: open and check a log once, step a system through it once, and hand
every cycle to the observers that gather what they need from it (the verdict, traces,
the fields read, timelines, a failed DTC's details), the way py_trees hangs visitors
off one tick loop.

The verdict (a :class:`Judge`) judges most cycles from the replayed state changes
alone, on the hot path. Stepping stops for good when no observer needs more replayed
cycles; reading stops when none reads on, or at the log's end where a judge must see
every byte of it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import Any, Protocol, TypedDict, Unpack

from beatlog.log.files import Closing
from beatlog.log.format import CycleRecord, LoggedStateChange
from beatlog.log.reader import SessionLogReader
from beatlog.log.recording import LogSource
from beatlog.model.behavior import System
from beatlog.model.perception import Perception
from beatlog.model.setup import SystemFactory
from beatlog.replay.approved_states import ApprovedStateChecker
from beatlog.replay.core import AGREED, CycleOutcome, Replayer
from beatlog.replay.cycle_reader import RecordedStates
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.random import ReplayRandom
from beatlog.replay.setup import built_for_replay

__all__ = [
    "BatchReader",
    "Calling",
    "FieldsRead",
    "Judge",
    "Observer",
    "ReadTracker",
    "ReplayOptions",
    "ReplaySession",
    "fields_read",
]


class Observer(Protocol):
    """What a replay session hands its cycles to."""

    @property
    def replaying(self) -> bool:
        """Whether it still needs cycles replayed (their outcomes)."""

    @property
    def reading(self) -> bool:
        """Whether it still needs cycles at all (the recording alone, past the replay)."""

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        """Take the next recorded cycle and, while the session replays, its outcome."""


class BatchReader(Protocol):
    """What reads the recording alone, a batch at a time, as a replay session reads
    the log: the whole log, whatever the observers need."""

    def read(self, batch: Sequence[CycleRecord]) -> None:
        """Take the log's next batch, as recorded."""


class Judge(Protocol):
    """The verdict, as a replay session hands it the cycles: the replay core compares
    each cycle with the bytes expected of it
    (:meth:`~beatlog.replay.core.Replayer.check_bytes`), and the judge judges the cycles
    that did not agree at once, building a cycle's full outcome only where it does not
    agree at all."""

    def batches(self, batches: Iterator[Sequence[CycleRecord]]) -> Iterator[Sequence[CycleRecord]]:
        """The log's batches as it judges them."""

    def judge(
        self,
        index: int,
        record: CycleRecord,
        changes: list[LoggedStateChange] | None,
        outcome: CycleOutcome | None,
    ) -> Observer | None:
        """Judge the cycle replayed last, the ``index``-th of its batch, which did not
        agree at once: ``changes`` is what :meth:`~beatlog.replay.core.Replayer.advance`
        returned, ``outcome`` the cycle's outcome where other observers asked for it.
        Where judging stops, the observer that follows replay past that cycle, which
        alone the session goes on for: the others take the cycles up to that one."""


class Calling:
    """A callback as an observer: given every cycle's outcome."""

    replaying = reading = True

    def __init__(self, call: Callable[[CycleOutcome], object]) -> None:
        self._call = call

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        """Hand the callback the cycle's outcome."""
        if outcome is not None:
            self._call(outcome)


class ReadTracker:
    """Stands in for a robot state and notes which fields the behaviors read."""

    def __init__(self) -> None:
        self._state: Any = None
        self.read: dict[str, None] = {}

    def stand_in(self, state: Any) -> ReadTracker:
        """Stand in for ``state``."""
        self._state = state
        return self

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._state, name)
        self.read[name] = None
        return value


class FieldsRead:
    """Observes which robot-state fields the behaviors read in one ``cycle``: the
    session lets its :class:`ReadTracker` stand in for RS_t there.

    Empty when replay cannot get there (a cycle before it did not complete) or the
    behaviors do not accept the stand-in state.
    """

    def __init__(self, cycle: int) -> None:
        self.cycle = cycle
        self.tracker = ReadTracker()
        self._next = 0
        self._lost = False

    @property
    def replaying(self) -> bool:
        return not self._lost and self._next <= self.cycle

    reading = replaying

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        if outcome is None:
            return
        if outcome.cycle < self.cycle and not outcome.completed:
            self._lost = True
        self._next = outcome.cycle + 1

    @property
    def fields(self) -> tuple[str, ...]:
        """The fields read in the cycle, in the order first read."""
        if self._lost or self._next <= self.cycle:
            return ()
        return tuple(self.tracker.read)


class ReplayOptions(TypedDict, total=False):
    """How a :class:`ReplaySession` replays: the keyword arguments it passes on to its
    :class:`~beatlog.replay.core.Replayer`, each as the replayer documents it."""

    perception: Perception | None
    break_at: int | None
    match_draws: bool
    rename: Callable[[str], str]
    migration: StateMigration | None
    approved_states: ApprovedStateChecker | None


class ReplaySession(Closing):
    """A log opened and checked once, and a system set up to replay it; a context manager.

    Building one reads the header, builds the system where it is given its factory or
    its ``module:factory`` reference (:mod:`beatlog.replay.setup`) and checks that the
    log fits it (:mod:`beatlog.replay.fit`); the ``options`` go to its
    :class:`~beatlog.replay.core.Replayer`. :meth:`run` steps through the log for
    its observers. Without a system, nothing is replayed: the observers read the
    recording alone.

    ``fresh_from`` (a cycle) starts the behaviors from rest there: the system first
    updates in that cycle, at the cycle number and robot time recorded for it, its BS_t
    found against the behavior states recorded before it
    (:meth:`~beatlog.model.cycle.CycleExecutor.assume`); the cycles before it are read
    and checked, not replayed, and no observer gets them.
    """

    def __init__(
        self,
        log: LogSource,
        system: System | SystemFactory | str | None,
        *,
        fresh_from: int = 0,
        **options: Unpack[ReplayOptions],
    ) -> None:
        self.reader = reader = SessionLogReader(log)
        self.fresh_from = fresh_from
        self._rename = options.get("rename", str)
        try:
            self.replayer: Replayer | None = None
            if system is not None:
                random = ReplayRandom()
                header, path = reader.header, reader.path
                built = built_for_replay(system, header, path, random)
                self.replayer = Replayer(built, header, path, random=random, **options)
                self.replayer.executor.context.cycle = fresh_from - 1
        except BaseException:
            self.reader.close()
            raise

    def run(
        self,
        observers: Sequence[Observer],
        *,
        judge: Judge | None = None,
        fields_read: FieldsRead | None = None,
        readers: Sequence[BatchReader] = (),
    ) -> None:
        """Step through the log once for ``observers``, ``judge`` (the verdict) and
        ``fields_read`` (whose tracker stands in for the robot state in its cycle),
        until none needs more. With a judge the log is read to its end: a damaged log
        is bad input, wherever the damage is; ``readers`` take each of its batches as
        recorded, to its end."""
        watching: list[Observer] = [*observers, *([fields_read] if fields_read else [])]
        batches = self._batches()
        if readers:
            batches = _read_by(readers, batches)
        to_end = judge is not None or bool(readers)
        replayer = self.replayer
        verdict = None  # without a system, the recording alone: nothing to judge
        if replayer is not None:
            advance, outcome_of = replayer.advance, replayer.outcome
            if judge is not None:
                batches, verdict = judge.batches(batches), judge.judge
            if fields_read is not None:
                context = replayer.executor.context
                tracker, at = fields_read.tracker, fields_read.cycle
                replayer.observe = lambda state: (
                    tracker.stand_in(state) if context.cycle + 1 == at else state
                )
        replaying = replayer is not None
        observing = False
        for batch in batches:
            for index, record in enumerate(batch):
                if watching:
                    watching = [observer for observer in watching if observer.reading]
                    observing = replaying and any(observer.replaying for observer in watching)
                replaying = observing or verdict is not None
                if not replaying:
                    if not watching and not to_end:
                        return
                    for observer in watching:
                        observer.add(record, None)
                    continue
                changes = advance(record)
                outcome = outcome_of() if observing else None
                for observer in watching:
                    observer.add(record, outcome)
                if verdict is not None and changes is not AGREED:
                    follower = verdict(index, record, changes, outcome)
                    if follower is not None:
                        verdict = None
                        watching = [follower]  # the others saw the cycle that stops it

    def _batches(self) -> Iterator[Sequence[CycleRecord]]:
        """The log's batches, from the fresh start on where there is one: there the
        clock is set to the robot time recorded before it, and the behavior states
        recorded then assumed, once they are known (its batch read)."""
        if not self.fresh_from or self.replayer is None:
            yield from self.reader.batches()
            return
        executor, reader = self.replayer.executor, self.reader
        recorded = RecordedStates(reader.path, reader.header.behaviors)
        for number, batch in enumerate(reader.batches(self.fresh_from, recorded.take)):
            if not number:
                now_ns = reader.robot_time_ns - sum([c.heartbeat_ns for c in batch])
                executor.clock.now_ns = executor.context.time_ns = now_ns
                executor.assume(recorded.by_position(executor.behavior_ids, self._rename))
            yield batch

    def close(self) -> None:
        """Close the log."""
        self.reader.close()


def _read_by(
    readers: Sequence[BatchReader], batches: Iterator[Sequence[CycleRecord]]
) -> Iterator[Sequence[CycleRecord]]:
    """``batches``, each read by ``readers`` first."""
    for batch in batches:
        for reader in readers:
            reader.read(batch)
        yield batch


def fields_read(
    log: LogSource,
    system: System | SystemFactory | str,
    cycle: int,
    *,
    migration: StateMigration | None = None,
    fresh_from: int = 0,
) -> tuple[str, ...]:
    """The robot-state fields a fresh ``system`` (or one its factory or reference builds)
    reads in ``cycle`` of ``log``, in order (see :class:`FieldsRead`), the log's fields
    renamed and converted by ``migration``; from rest at ``fresh_from`` (see
    :class:`ReplaySession`)."""
    reads = FieldsRead(cycle)
    with ReplaySession(log, system, migration=migration, fresh_from=fresh_from) as session:
        session.run([], fields_read=reads)
    return reads.fields
