"""How a cycle that did not agree diverges: its kind, the message naming the behavior
and call, the robot-state fields and draws, and the cycles around it.

The judge (:mod:`beatlog.replay.judge`) compares each cycle's bytes and hands the
cycles that differ here: :class:`Divergences` first asks whether the cycle still
agrees but for what an approved baseline pins (robot states by digest, draws
approved), and if not writes the first divergence up and counts the others.
"""

from __future__ import annotations

import dataclasses
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

import msgspec

from beatlog.log.format import CycleRecord, StateChangeRecord, payload_encoder
from beatlog.model.perception import PerceptionTypeError
from beatlog.model.random import Draw, plain_value
from beatlog.replay.compare import Comparison, state_fields
from beatlog.replay.core import CycleOutcome, Replayer, actor_name
from beatlog.replay.draws import DrawLedger, Unapproved
from beatlog.replay.pins import PinChecker, rebuilt_otherwise
from beatlog.replay.renames import propose_renames
from beatlog.replay.verdict import (
    ContextRow,
    Divergence,
    DivergenceKind,
    DrawReport,
    FieldDifference,
    StateChange,
)
from beatlog.usercode import user_traceback

__all__ = ["Divergences", "Follower"]


class Divergences:
    """Writes up the first divergence of a replay, with up to ``context`` cycles either
    side, and counts the cycles that diverge.

    ``named`` turns a record's expected state changes into current names, and
    ``outputs_of`` decodes its expected outputs; ``ledger`` holds the draws an approved
    baseline approves, ``pinned_states`` the robot-state fields a format 3 baseline
    pins by cycle; ``against`` and ``outputs_against`` say what replay is judged against.
    """

    def __init__(
        self,
        replayer: Replayer,
        comparison: Comparison,
        *,
        context: int,
        keep_going: bool,
        named: Callable[[msgspec.Raw], list[StateChange]],
        outputs_of: Callable[[msgspec.Raw], dict[str, Any]],
        expected_names: Sequence[str],
        ledger: DrawLedger | None,
        pinned_states: dict[int, dict[str, Any]],
        against: tuple[str, str],
    ) -> None:
        self.replayer = replayer
        self.comparison = comparison
        self.context = context
        """Cycles shown either side of the first divergence."""
        self._keep_going = keep_going
        self._named = named
        self._outputs_of = outputs_of
        self._expected_names = expected_names
        self._ledger = ledger
        self._pinned_states = pinned_states
        self._state_pins: PinChecker | None = (
            replayer.state_pins if replayer.perception is not None else None
        )
        self._against, self._outputs_against = against
        self._encoder = payload_encoder()
        self._batches: deque[Sequence[CycleRecord]] = deque(maxlen=context + 1)
        """The last batches: they hold the cycles before a divergence (none is empty)."""
        self._recent: list[CycleRecord] = []
        """The cycles before the first divergence, then the divergence."""
        self.divergence: Divergence | None = None
        self.divergent_cycles = 0
        self.samples_diverged = 0
        """The samples of the cycles that diverged."""

    def remember(self, batch: Sequence[CycleRecord]) -> None:
        """Keep a batch the judge is about to replay, for the cycles before a divergence."""
        self._batches.append(batch)

    def named_actual(self, changes: list[StateChangeRecord]) -> list[StateChange]:
        """State changes the behaviors made, by name."""
        names = self.replayer.executor.behavior_ids
        return [StateChange(names[index], before, after) for index, before, after in changes]

    def agrees_but_for_pins(self, outcome: CycleOutcome) -> bool:
        """Whether a cycle the core did not call clean went cleanly but for what the
        approved baseline pins: perception rebuilt the robot state as expected (within
        tolerance, or as pinned), and the draws made otherwise than recorded are ones
        the baseline approves (which they then use up)."""
        if not outcome.completed or outcome.perception_failure is not None:
            return False
        if (
            self.replayer.perception is not None
            # A rebuilt state the core found as expected (the recorded one, or as
            # pinned) differs only where a format 3 baseline pins other values.
            and (outcome.perception_differs or outcome.cycle in self._pinned_states)
            and self._state_differences(outcome)
        ):
            return False
        differences = outcome.draw_differences
        if self._ledger is None:
            return not differences
        return self._ledger.check(outcome.cycle, differences or ()) is None

    def add(self, outcome: CycleOutcome, index: int) -> None:
        """A cycle that diverged, the ``index``-th of the batch last remembered."""
        first = self.divergence is None
        if first:
            self._recent = self._window(index)
        self._diverge(outcome)
        if first and self._keep_going:
            self._add_context([])

    def _window(self, index: int) -> list[CycleRecord]:
        """The cycle at ``index`` in the last batch, with up to ``context`` cycles before it."""
        *earlier, last = self._batches
        records = [record for batch in earlier for record in batch]
        records.extend(last[: index + 1])
        return records[-(self.context + 1) :]

    def followed(self, rows: list[ContextRow], *, suspect: bool) -> None:
        """Write the cycles replayed past the divergence into it and, where the
        divergence looked like a renamed behavior (``suspect``) all through the rest of
        the log, the rename map they propose."""
        self._add_context(rows[: self.context])
        if suspect and self.divergence is not None:
            kept = self.comparison.kept
            cycles = [(self.divergence.expected, self.divergence.actual)]
            cycles.extend((row.expected, row.actual) for row in rows)
            renames = propose_renames((kept(want), kept(got)) for want, got in cycles)
            self.divergence = dataclasses.replace(self.divergence, proposed_renames=renames)

    def rename_suspected(self) -> bool:
        """Whether the divergence is in state changes and expected behaviors are missing:
        replay past it then follows the whole rest of the log, for a rename map."""
        if self.divergence is None or self.divergence.kind is not DivergenceKind.STATE_CHANGES:
            return False
        rename = self.comparison.rename
        current = set(self.replayer.executor.behavior_ids)
        return not {rename(name) for name in self._expected_names} <= current

    def row(self, outcome: CycleOutcome) -> ContextRow:
        """A cycle replayed past the divergence, as its context shows it."""
        return ContextRow(
            outcome.cycle,
            outcome.time_ns,
            tuple(self._named(outcome.record.state_changes)),
            tuple(self.named_actual(outcome.changes or [])),
        )

    def _add_context(self, after: list[ContextRow]) -> None:
        divergence = self.divergence
        if divergence is None:
            return
        recent = self._recent
        time_ns = divergence.time_ns
        before: list[ContextRow] = []
        for offset in range(1, len(recent)):
            time_ns -= recent[-offset].heartbeat_ns
            expected = tuple(self._named(recent[-offset - 1].state_changes))
            before.append(ContextRow(divergence.cycle - offset, time_ns, expected, expected))
        here = ContextRow(
            divergence.cycle, divergence.time_ns, divergence.expected, divergence.actual
        )
        rows = [*reversed(before), here, *after]
        context = tuple(row for row in rows if row is here or row.expected or row.actual)
        self.divergence = dataclasses.replace(divergence, context=context)

    def log_ended(self, why: str, cycle: int, time_ns: int) -> None:
        """Record that the log stopped before the recording closed it, after ``cycle``."""
        if self.divergence is None:
            self.divergence = Divergence(
                kind=DivergenceKind.LOG_ENDED,
                cycle=cycle + 1,
                time_ns=time_ns,
                message=f"the log ends early ({why}); if the session ended there (a crash), "
                "accept what it holds with --allow-truncated (in a spec: allow_truncated = true)",
            )
        self.divergent_cycles += 1

    def _diverge(self, outcome: CycleOutcome) -> None:
        self.divergent_cycles += 1
        self.samples_diverged += len(outcome.samples)
        if self.divergence is not None:
            return
        record = outcome.record
        expected = self._named(record.state_changes)
        actual = self.named_actual(outcome.changes or [])
        failure = outcome.failure
        trace: str | None = None
        differences = (
            self._state_differences(outcome)
            if self.replayer.perception is not None and outcome.perception_failure is None
            else ()
        )
        stop = self.replayer.stop(outcome)
        unapproved = (
            None
            if self._ledger is None
            else self._ledger.check(outcome.cycle, outcome.draw_differences or ())
        )
        behavior: str | None = None
        kind: DivergenceKind
        if stop is not None and stop.kind is DivergenceKind.PERCEPTION:
            kind, message = stop.kind, stop.message
            problem = outcome.perception_failure
            if problem is not None and not isinstance(problem, PerceptionTypeError):
                trace = user_traceback(problem)
        elif differences:
            kind = DivergenceKind.PERCEPTION
            message = self._perception_message(outcome, differences)
        elif stop is not None and stop.kind is not DivergenceKind.RANDOM_UNDERDRAWN:
            kind, message, behavior = stop
            if failure is not None:
                trace = user_traceback(failure)
        elif unapproved is not None and unapproved.made and unapproved.difference.asked:
            kind, message, behavior = _unapproved(unapproved)
        elif not self.comparison.changes_agree(expected, actual):
            # The first behavior difference is the headline, even when the changed
            # behavior then drew fewer random numbers than were recorded.
            kind = DivergenceKind.STATE_CHANGES
            message = f"behavior state changes differ from {self._against}"
            behavior = self.comparison.first_differing_behavior(expected, actual)
            if stop is not None:
                message += f", and then the behaviors {stop.message}"
        elif stop is not None:
            kind, message, behavior = stop
        elif unapproved is not None:
            kind, message, behavior = _unapproved(unapproved)
        else:
            kind = DivergenceKind.OUTPUTS
            message = f"outputs differ from {self._outputs_against}"
        if kind is not DivergenceKind.STATE_CHANGES and self.comparison.only_order_differs(
            expected, actual
        ):
            message += (
                "; the state changes differ only in the order behaviors are listed,"
                " which is no difference"
            )
        completed = failure is None and outcome.draw_problem is None
        self.divergence = Divergence(
            kind=kind,
            cycle=outcome.cycle,
            time_ns=outcome.time_ns,
            message=message,
            behavior=behavior,
            expected=tuple(expected),
            actual=tuple(actual),
            expected_outputs=self._outputs_of(record.outputs),
            actual_outputs=dict(outcome.outputs) if completed else {},
            robot_state=state_fields(outcome.state),
            random_recorded=tuple(_reports(outcome.recorded_draws, self.replayer.header.behaviors)),
            random_drawn=tuple(_reports(outcome.drawn, self.replayer.executor.behavior_ids)),
            traceback=trace,
            perception=differences,
            samples=tuple((sample.sensor, sample.value) for sample in outcome.samples),
        )

    def _state_differences(self, outcome: CycleOutcome) -> tuple[FieldDifference, ...]:
        """The robot-state fields perception rebuilt otherwise than expected, beyond their
        tolerance: expected is the recorded RS_t with the fields a format 3 baseline pins.

        In a cycle pinned by digest the whole state is judged, bit for bit; when it
        differs, the fields named are those that differ from the recording now or did
        in the approved baseline's run of cycles, recorded against rebuilt.
        """
        expected = state_fields(outcome.recorded_state)
        actual = state_fields(outcome.state)
        pins = self._state_pins
        if pins is not None and outcome.cycle in pins:
            if pins.found(outcome.cycle, self._state_bytes(outcome.state)) is None:
                return ()
            named = {*pins.run_at(outcome.cycle).fields, *rebuilt_otherwise(expected, actual)}
            return tuple(
                FieldDifference(name, expected.get(name), actual.get(name))
                for name in dict.fromkeys([*expected, *actual])
                if name in named
            )
        expected.update(self._pinned_states.get(outcome.cycle, ()))
        return tuple(
            FieldDifference(name, expected.get(name), actual.get(name))
            for name in self.comparison.state_differences(expected, actual)
        )

    def _state_bytes(self, state: Any) -> bytes:
        """A robot state as a log encodes it; no bytes where it cannot be encoded."""
        try:
            return self._encoder.encode(state)
        except (TypeError, msgspec.EncodeError):
            return b""

    def _perception_message(
        self, outcome: CycleOutcome, differences: tuple[FieldDifference, ...]
    ) -> str:
        """Why the robot state rebuilt in a cycle is not the one expected."""
        pins = self._state_pins
        if pins is None or outcome.cycle not in pins:
            names = ", ".join(d.field for d in differences)
            pinned = self._pinned_states or (pins and pins.cycles)
            against = " from the approved baseline" if pinned else ""
            return f"the robot state rebuilt from the samples differs{against} in {names}"
        run = pins.run_at(outcome.cycle)
        rebuilt = state_fields(outcome.state)
        now = list(rebuilt_otherwise(state_fields(outcome.recorded_state), rebuilt))
        return (
            "the robot state rebuilt from the samples differs from the approved baseline "
            f"{pins.found(outcome.cycle, self._state_bytes(outcome.state))}; "
            "it differs from the recording in "
            f"{', '.join(now) or 'no field'}, the approved one in {', '.join(run.fields)} "
            f"(cycles {run.cycle}–{run.last})"
        )


def _unapproved(unapproved: Unapproved) -> tuple[DivergenceKind, str, str]:
    """How a draw made otherwise than recorded, and not as approved, diverges."""
    (behavior, recorded, asked), made, elsewhere = unapproved
    if not made:
        what = (
            f"a new {asked}"
            if recorded is None
            else f"{recorded} left unused"
            if asked is None
            else f"{recorded} re-mapped to {asked}"
        )
        message = f"{behavior} did not make the draw the approved baseline holds: {what}"
        return DivergenceKind.RANDOM_UNDERDRAWN, message, behavior
    where = " in this cycle" if elsewhere else ""
    baseline = f"which the approved baseline does not hold{where}"
    if recorded is None:
        message = f"{behavior} called {asked}, a draw the recording does not have, {baseline}"
        return DivergenceKind.RANDOM_OVERDRAWN, message, behavior
    if asked is None:
        message = f"{behavior} did not draw the recorded {recorded}, {baseline}"
        return DivergenceKind.RANDOM_UNDERDRAWN, message, behavior
    message = f"{behavior} called {asked} where {recorded} was recorded, {baseline}"
    return DivergenceKind.RANDOM_MISMATCH, message, behavior


def _reports(draws: Sequence[Draw], names: Sequence[str]) -> list[DrawReport]:
    return [
        DrawReport(actor_name(names, d.actor), d.kind, plain_value(d), d.call() if d.params else "")
        for d in draws
    ]


class Follower:
    """Follows replay past the first divergence, as an observer of the replay session:
    a few cycles to show what happened next, or the whole rest of the log when the
    divergence looks like a renamed behavior; :meth:`end` writes them into it."""

    def __init__(self, divergences: Divergences) -> None:
        self._divergences = divergences
        self._suspect = divergences.rename_suspected()
        self._rows: list[ContextRow] = []
        self._limit = None if self._suspect else divergences.context
        self._done = False
        if self._limit == 0:
            self.end()

    @property
    def replaying(self) -> bool:
        """Whether it follows still."""
        return not self._done

    @property
    def reading(self) -> bool:
        """Whether it needs more cycles."""
        return not self._done

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        """Take the next cycle past the divergence; replay cannot go on past one that
        does not go cleanly."""
        if self._done or outcome is None:
            return
        if outcome.changes is None or outcome.failure is not None:
            self._suspect = False  # the first divergence is reported; replay cannot go on
            self.end()
            return
        self._rows.append(self._divergences.row(outcome))
        if len(self._rows) == self._limit:
            self.end()

    def end(self) -> None:
        """Write what was followed into the divergence (once)."""
        if not self._done:
            self._done = True
            self._divergences.followed(self._rows, suspect=self._suspect)
