"""The replay core: the one place that steps a system through a session log.

For each recorded cycle t it decodes RS_t, loads RN_t into the random source,
advances the simulated clock by HB_t and updates the behaviors, then hands back a
:class:`CycleOutcome` with everything anyone needs: the recording, the state the
behaviors saw, what they changed and output, the random numbers drawn against the
recorded ones, and any problem. The verdict (:mod:`beatlog.replay.judge`), traces,
the fields read, timelines and the audit all consume these outcomes; nothing else
steps a system through a log.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from beatlog.errors import BeatlogError, CorruptLogError, SchemaMismatchError
from beatlog.log.format import (
    DECODE_ERRORS,
    EMPTY_LIST,
    CycleRecord,
    SessionHeader,
    StateChangeRecord,
)
from beatlog.model.behavior import System
from beatlog.model.context import Outputs
from beatlog.model.cycle import CycleExecutor
from beatlog.model.random import Draw, RandomMismatch, ReplayRandom
from beatlog.replay.fit import check_fit

__all__ = ["CycleOutcome", "Replayer"]


class CycleOutcome(NamedTuple):
    """What happened when the system replayed one recorded cycle."""

    cycle: int
    time_ns: int
    """Robot time at the end of the cycle."""
    record: CycleRecord
    """The recorded cycle: HB_t, RS_t, BS_t, RN_t and outputs, still encoded."""
    state: Any
    """RS_t as the behaviors saw it."""
    changes: list[StateChangeRecord] | None
    """BS'_t, the replayed state changes; None when the update did not complete."""
    outputs: Outputs
    """The replayed outputs (as far as the update got)."""
    recorded_draws: Sequence[Draw]
    drawn: Sequence[Draw]
    """The random numbers the behaviors drew, with what they asked for."""
    draw_problem: RandomMismatch | None
    """A draw that did not match the recording (another kind or request, or one too many)."""
    failure: BaseException | None
    """What the behavior code raised (including ``SystemExit``), if it did."""
    actor: int
    """The behavior that was running when the update stopped (-1: the system itself)."""

    @property
    def underdrawn(self) -> bool:
        """Whether fewer random numbers were drawn than were recorded."""
        return len(self.drawn) < len(self.recorded_draws)

    @property
    def completed(self) -> bool:
        """Whether the update ran to its end and drew exactly the recorded numbers."""
        return (
            self.changes is not None
            and self.draw_problem is None
            and len(self.drawn) == len(self.recorded_draws)
        )


class Replayer:
    """A system set up to replay the cycles of one log, in order, from its first.

    Building one checks that the log fits the system (:mod:`beatlog.replay.fit`).
    """

    def __init__(self, system: System, header: SessionHeader, path: Path) -> None:
        check_fit(header, system, path)
        self.system = system
        self.header = header
        self.path = path
        self.random = ReplayRandom()
        self.executor = CycleExecutor(system, self.random)
        self._state = msgspec.msgpack.Decoder(system.robot_state).decode
        self._draws = msgspec.msgpack.Decoder(list[Draw]).decode

    def step(
        self, record: CycleRecord, *, observe: Callable[[Any], Any] | None = None
    ) -> CycleOutcome:
        """Replay the next cycle; ``observe`` may wrap RS_t before the behaviors see it.

        :raises beatlog.errors.LogError: the cycle's robot state or random numbers are
            damaged or do not fit the system.
        """
        executor = self.executor
        random = self.random
        cycle = executor.context.cycle + 1
        state = self._decode_state(record, cycle)
        random.load(
            () if record.random_numbers == EMPTY_LIST else self._decode_draws(record, cycle)
        )
        changes: list[StateChangeRecord] | None = None
        failure: BaseException | None = None
        try:
            changes = executor.step(
                record.heartbeat_ns, state if observe is None else observe(state)
            )
        except RandomMismatch:
            pass
        except BeatlogError:
            raise
        except (Exception, SystemExit) as exc:  # behavior code failing is an outcome
            failure = exc
        context = executor.context
        return CycleOutcome(
            context.cycle,
            context.time_ns,
            record,
            state,
            changes,
            context.outputs,
            random.recorded,
            random.drawn,
            random.mismatch,
            failure,
            context.actor,
        )

    def outcomes(self, records: Iterable[CycleRecord]) -> Iterator[CycleOutcome]:
        """Replay ``records`` one after another."""
        step = self.step
        for record in records:
            yield step(record)

    def _decode_state(self, record: CycleRecord, cycle: int) -> Any:
        try:
            return self._state(record.robot_state)
        except DECODE_ERRORS as exc:
            raise SchemaMismatchError(
                self.path,
                f"robot state of cycle {cycle} does not fit "
                f"{self.system.robot_state.__name__}: {exc}",
            ) from None

    def _decode_draws(self, record: CycleRecord, cycle: int) -> list[Draw]:
        try:
            return self._draws(record.random_numbers)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(
                self.path, f"damaged random numbers in cycle {cycle}: {exc}"
            ) from None
