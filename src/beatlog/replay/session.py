"""A replay session: open and check a log once, step a system through it once, and hand
every cycle to the observers that gather what they need from it.

Traces, the fields read, timelines and a failed DTC's details are observers of one
session, the way py_trees hangs visitors off one tick loop: none of them opens a log
or steps a system on its own. Stepping stops for good when no observer needs more
replayed cycles (a replay cannot resume once skipped); the recording alone goes on to
the observers that still read it, and reading stops when none does.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any, Protocol, TypedDict, Unpack

from beatlog.closing import Closing
from beatlog.log.format import CycleRecord
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import System
from beatlog.model.perception import Perception
from beatlog.replay.core import CycleOutcome, Replayer
from beatlog.replay.migration import StateMigration
from beatlog.replay.pins import PinChecker

__all__ = ["FieldsRead", "Observer", "ReadTracker", "ReplayOptions", "ReplaySession", "fields_read"]


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

    @property
    def reading(self) -> bool:
        return self.replaying

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
    living: bool
    rename: Callable[[str], str]
    migration: StateMigration | None
    state_pins: PinChecker | None


class ReplaySession(Closing):
    """A log opened and checked once, and a system set up to replay it; a context manager.

    Building one reads the header and checks that the log fits the system
    (:mod:`beatlog.replay.fit`), its robot-state fields renamed and converted by
    ``migration``; ``state_pins``, an approved baseline's robot states, are what
    perception must rebuild in their cycles. :meth:`run` steps through the log for its
    observers.
    Without a system, nothing is replayed: the observers read the recording alone.
    ``break_at`` stops in the debugger just before the behaviors update in that cycle.
    ``living`` replay goes on where the behaviors draw otherwise than recorded
    (:meth:`~beatlog.model.random.ReplayRandom.live`; ``rename`` maps a recorded
    behavior's name to its name now), as it does judged against an approved baseline.

    The verdict (:func:`beatlog.replay.judge.replay`) steps the session's replayer in
    a loop of its own, which builds a cycle's full outcome only where the cycle does
    not agree with the recording (and for an ``observe`` callback): the hot path.
    """

    def __init__(
        self,
        log: str | Path,
        system: System | None,
        **options: Unpack[ReplayOptions],
    ) -> None:
        self.reader = SessionLogReader(log)
        try:
            self.replayer = (
                None
                if system is None
                else Replayer(system, self.reader.header, self.reader.path, **options)
            )
        except BaseException:
            self.reader.close()
            raise

    def records(self) -> Iterator[CycleRecord]:
        """The log's cycles, in order, read batch by batch."""
        for batch in self.reader.batches():
            yield from batch

    def run(self, observers: Sequence[Observer], *, fields_read: FieldsRead | None = None) -> None:
        """Step through the log once for ``observers`` (and ``fields_read``, whose
        tracker stands in for the robot state in its cycle), until none needs more."""
        everyone: list[Observer] = [*observers, *([fields_read] if fields_read else [])]
        step = None if self.replayer is None else self.replayer.step
        replaying = True
        for cycle, record in enumerate(self.records()):
            reading = [observer for observer in everyone if observer.reading]
            if not reading:
                return
            replaying = replaying and any(observer.replaying for observer in reading)
            outcome = None
            if replaying and step is not None:
                stand_in: Callable[[Any], Any] | None = None
                if fields_read is not None and cycle == fields_read.cycle:
                    stand_in = fields_read.tracker.stand_in
                outcome = step(record, observe=stand_in)
            for observer in reading:
                observer.add(record, outcome)

    def close(self) -> None:
        """Close the log."""
        self.reader.close()


def fields_read(
    log: str | Path, system: System, cycle: int, *, migration: StateMigration | None = None
) -> tuple[str, ...]:
    """The robot-state fields a fresh ``system`` reads in ``cycle`` of ``log``, in order
    (see :class:`FieldsRead`), the log's fields renamed and converted by ``migration``."""
    reads = FieldsRead(cycle)
    with ReplaySession(log, system, migration=migration) as session:
        session.run([], fields_read=reads)
    return reads.fields
