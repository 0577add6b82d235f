"""The first divergence written up, for the judge (:mod:`beatlog.replay.judge`): why
a cycle differs (its kind, and a message naming the behavior and call), what was
expected of it beside what it did, and the cycles around it, with the rename map they
propose where the behaviors differ from those expected only by a consistent renaming.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import msgspec

from beatlog.log.format import CycleRecord, LoggedStateChange, payload_encoder
from beatlog.log.payload import decode_outputs, decode_part
from beatlog.model.perception import PerceptionTypeError
from beatlog.project.usercode import user_traceback
from beatlog.replay.approved_states import rebuilt_otherwise
from beatlog.replay.baseline import BaselineStream
from beatlog.replay.compare import Comparison, state_fields
from beatlog.replay.core import ByteCheck, CycleOutcome, Replayer
from beatlog.replay.cycle_reader import recorded_changes
from beatlog.replay.departures import BaselineRecords
from beatlog.replay.draws import DrawApprovals, UnapprovedDraw
from beatlog.replay.outcome import random_draws
from beatlog.replay.verdict import (
    ContextRow,
    Divergence,
    DivergenceKind,
    FieldDifference,
    StateChange,
)

__all__ = ["DivergenceWriter", "Follower", "propose_renames"]


class DivergenceWriter:
    """What is expected of the cycles of ``replayer``'s replay (the recording, or the
    ``expected`` baseline: its state changes and outputs, the draws and robot states it
    approves), and the write-up of the first that differs, with up to ``context``
    cycles either side; a cycle before ``start`` is before the window."""

    def __init__(
        self,
        replayer: Replayer,
        comparison: Comparison,
        baseline: BaselineStream | None,
        *,
        start: int,
        context: int,
    ) -> None:
        self.replayer, self.comparison = replayer, comparison
        self._start, self._context = start, context
        behaviors = replayer.header.behaviors
        self._states = replayer.approved_states if replayer.perception is not None else None
        self._approved_draws = None if baseline is None else DrawApprovals(baseline.draws)
        self.records = None
        """The recorded cycles as the baseline expects them (None: as recorded)."""
        if baseline is not None:
            self.records = BaselineRecords(baseline, behaviors, comparison.rename, self._states)
        self.names = list(behaviors) if self.records is None else self.records.names
        """The catalogue of behaviors the expected state changes name."""
        departs = baseline is not None and baseline.departs
        self._against = "the approved baseline" if departs else "the recording"
        self._encoder = payload_encoder()
        self._batches: deque[Sequence[CycleRecord]] = deque(maxlen=context + 1)
        """The last batches: they hold the cycles before a divergence (none is empty)."""
        self._before: list[ContextRow] = []

    def check_bytes(self, *, judged: bool) -> None:
        """Have the replay core compare each cycle with the bytes expected of it
        (:class:`~beatlog.replay.core.ByteCheck`; ``judged``: none agrees at once)."""
        names, at = self.replayer.executor.behavior_ids, dict[str, int]()
        for position, name in enumerate(self.names):
            at.setdefault(self.comparison.rename(name), position)
        self.replayer.check_bytes(
            ByteCheck(
                None if names == self.names else [at.get(name, -1) for name in names],
                self._encoder,
                judged,
                None if self._approved_draws is None else self._approved_draws.approves,
            )
        )

    def keep(self, batch: Sequence[CycleRecord]) -> None:
        """Keep the batch replay reads next, for the cycles before a divergence."""
        self._batches.append(batch)

    def _expected(self, raw_changes: msgspec.Raw) -> list[StateChange]:
        """The state changes expected of the cycle replayed last, in current names.

        :raises beatlog.errors.CorruptLogError: one names a behavior the catalogue lacks.
        """
        replayer, names, renamed = self.replayer, self.names, self.comparison.renamed
        cycle = replayer.executor.context.cycle
        recorded = recorded_changes(replayer.path, raw_changes, cycle, len(names))
        return [renamed(StateChange(names[i], before, after)) for i, before, after in recorded]

    def _actual(self, changes: list[LoggedStateChange]) -> list[StateChange]:
        """State changes the behaviors made, by name."""
        names = self.replayer.executor.behavior_ids
        return [StateChange(names[i], before, after) for i, before, after in changes]

    def _outputs(self, raw_outputs: msgspec.Raw) -> dict[str, Any]:
        """The outputs expected of the cycle replayed last."""
        replayer = self.replayer
        cycle = replayer.executor.context.cycle
        return decode_part(replayer.path, raw_outputs, decode_outputs, "outputs", cycle)

    def agrees(self, record: CycleRecord, changes: list[LoggedStateChange]) -> bool:
        """Whether the state changes and outputs of the cycle replayed last match its
        ``record`` by the comparison (state changes as a set, allowances applied).

        :raises msgspec.EncodeError: they cannot be logged (or a ``TypeError`` or
            ``ValueError`` from an encoding hook).
        """
        compare, outputs = self.comparison, self.replayer.executor.context.outputs
        return compare.changes_agree(
            self._expected(record.state_changes), self._actual(changes)
        ) and compare.outputs_agree(self._outputs(record.outputs), outputs)

    def allows(self, outcome: CycleOutcome) -> bool:
        """Whether a cycle the core did not call clean went cleanly but for what an
        approved baseline allows: perception rebuilt the robot state as expected, and
        the draws made otherwise than recorded are ones it approves (using them up)."""
        if not outcome.completed or outcome.perception_failure is not None:
            return False
        perceived = self.replayer.perception is not None and outcome.perception_differs
        if perceived and self._state_differences(outcome):
            return False
        differences = outcome.draws_otherwise
        if self._approved_draws is None:
            return not differences
        return self._approved_draws.check(outcome.cycle, differences or ()) is None

    def _state_differences(self, outcome: CycleOutcome) -> tuple[FieldDifference, ...]:
        """The robot-state fields perception rebuilt otherwise than expected, beyond their
        tolerance: expected is the recorded RS_t or, in a cycle of an approved robot
        state, its digest (the fields named then differ from the recording now or did in the
        baseline's run of cycles)."""
        expected, actual = state_fields(outcome.recorded_state), state_fields(outcome.state)
        approved = self._states
        if approved is None or outcome.cycle not in approved:
            named = set(self.comparison.state_differences(expected, actual))
        elif approved.found(outcome.cycle, self._state_bytes(outcome.state)) is None:
            return ()
        else:
            named = {*approved.run_at(outcome.cycle).fields, *rebuilt_otherwise(expected, actual)}
        return tuple(
            FieldDifference(name, expected.get(name), actual.get(name))
            for name in dict.fromkeys([*expected, *actual])
            if name in named
        )

    def first(self, index: int, outcome: CycleOutcome, violation: Divergence | None) -> Divergence:
        """The first divergence, of the ``index``-th cycle of the batch kept last; the
        cycles before it are kept for its context."""
        divergence = self._divergence(outcome, violation)
        *earlier, last = self._batches
        recent = [*itertools.chain(*earlier), *last[: index + 1]][-(self._context + 1) :]
        time_ns = divergence.time_ns
        for offset in range(1, len(recent)):
            time_ns -= recent[-offset].heartbeat_ns
            if expected := tuple(self._expected(recent[-offset - 1].state_changes)):
                row = ContextRow(divergence.cycle - offset, time_ns, expected, expected)
                self._before.insert(0, row)
        return divergence

    def _divergence(self, outcome: CycleOutcome, violation: Divergence | None) -> Divergence:
        """The divergence of a cycle, headed by why it differs (an invariant's
        ``violation``, if any), with what was expected of it beside what it did."""
        record = outcome.record
        expected = tuple(self._expected(record.state_changes))
        expected_outputs = self._outputs(record.outputs)
        recorded = tuple(random_draws(outcome.recorded_draws, self.replayer.header.behaviors))
        if violation is not None:
            return dataclasses.replace(
                violation,
                expected=expected,
                expected_outputs=expected_outputs,
                random_recorded=recorded,
            )
        actual = tuple(self._actual(outcome.changes or []))
        perceiving = self.replayer.perception is not None and outcome.perception_failure is None
        differences = self._state_differences(outcome) if perceiving else ()
        kind, message, behavior, failure = self._headline(outcome, expected, actual, differences)
        if kind is not DivergenceKind.STATE_CHANGES and self.comparison.only_order_differs(
            expected, actual
        ):
            message += (
                "; the state changes differ only in the order behaviors are listed,"
                " which is no difference"
            )
        if outcome.cycle < self._start:
            message = f"before the window (cycle {self._start} on): {message}"
        completed = outcome.failure is None and outcome.refused_draw is None
        return Divergence(
            kind=kind,
            cycle=outcome.cycle,
            time_ns=outcome.time_ns,
            message=message,
            behavior=behavior,
            expected=expected,
            actual=actual,
            expected_outputs=expected_outputs,
            actual_outputs=dict(outcome.outputs) if completed else {},
            robot_state=state_fields(outcome.state),
            random_recorded=recorded,
            random_drawn=tuple(random_draws(outcome.drawn, self.replayer.executor.behavior_ids)),
            traceback=None if failure is None else user_traceback(failure),
            perception=differences,
            samples=tuple((sample.sensor, sample.value) for sample in outcome.samples),
        )

    def _headline(
        self,
        outcome: CycleOutcome,
        expected: tuple[StateChange, ...],
        actual: tuple[StateChange, ...],
        differences: tuple[FieldDifference, ...],
    ) -> tuple[DivergenceKind, str, str | None, BaseException | None]:
        """Why a cycle differs: its kind, message and behavior, and what raised in it
        whose traceback the divergence shows."""
        stop = self.replayer.stop(outcome)
        draws = outcome.draws_otherwise or ()
        unapproved = (
            None
            if self._approved_draws is None
            else self._approved_draws.check(outcome.cycle, draws)
        )
        if stop is not None and stop.kind is DivergenceKind.PERCEPTION:
            problem = outcome.perception_failure
            shown = None if isinstance(problem, PerceptionTypeError) else problem
            return stop.kind, stop.message, None, shown
        if differences:
            message = self._perception_message(outcome, differences)
            return DivergenceKind.PERCEPTION, message, None, None
        if stop is not None and stop.kind is not DivergenceKind.RANDOM_UNDERDRAWN:
            return *stop, outcome.failure
        if unapproved is not None and unapproved.made and unapproved.draw.asked:
            return *_unapproved(unapproved), None
        if not self.comparison.changes_agree(expected, actual):
            # The first behavior difference is the headline, even when the changed
            # behavior then drew fewer random numbers than were recorded.
            message = f"behavior state changes differ from {self._against}"
            if stop is not None:
                message += f", and then the behaviors {stop.message}"
            behavior = self.comparison.first_differing_behavior(expected, actual)
            return DivergenceKind.STATE_CHANGES, message, behavior, None
        if stop is not None:
            return *stop, None
        if unapproved is not None:
            return *_unapproved(unapproved), None
        return DivergenceKind.OUTPUTS, f"outputs differ from {self._against}", None, None

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
        approved = self._states
        if approved is None or outcome.cycle not in approved:
            names = ", ".join(d.field for d in differences)
            against = " from the approved baseline" if approved and approved.pinned else ""
            return f"the robot state rebuilt from the samples differs{against} in {names}"
        run = approved.run_at(outcome.cycle)
        rebuilt = state_fields(outcome.state)
        now = list(rebuilt_otherwise(state_fields(outcome.recorded_state), rebuilt))
        return (
            "the robot state rebuilt from the samples differs from the approved baseline "
            f"{approved.found(outcome.cycle, self._state_bytes(outcome.state))}; "
            "it differs from the recording in "
            f"{', '.join(now) or 'no field'}, the approved one in {', '.join(run.fields)} "
            f"(cycles {run.cycle}–{run.last})"
        )

    def follower(self, divergence: Divergence) -> Follower:
        """What follows replay past ``divergence``: the cycles of its context or, where it
        looks like a renamed behavior (expected behaviors are missing), the rest of the
        log."""
        rename = self.comparison.rename
        suspect = divergence.kind is DivergenceKind.STATE_CHANGES and not {
            rename(name) for name in self.names
        } <= set(self.replayer.executor.behavior_ids)
        return Follower(self._row, None if suspect else self._context, suspect)

    def _row(self, outcome: CycleOutcome) -> ContextRow:
        """A cycle replayed past the divergence, as its context shows it."""
        expected = tuple(self._expected(outcome.record.state_changes))
        actual = tuple(self._actual(outcome.changes or []))
        return ContextRow(outcome.cycle, outcome.time_ns, expected, actual)

    def with_context(self, divergence: Divergence, follower: Follower | None) -> Divergence:
        """``divergence`` with the cycles around it that changed a behavior's state (those
        after it as ``follower`` followed them) and the rename map the rest of the log
        proposes where it looked like a renamed behavior."""
        here = ContextRow(
            divergence.cycle, divergence.time_ns, divergence.expected, divergence.actual
        )
        after = [] if follower is None else follower.rows
        shown = [*self._before, here, *after[: self._context]]
        context = tuple(row for row in shown if row is here or row.expected or row.actual)
        renames: dict[str, str] = {}
        if follower is not None and follower.suspect:
            kept = self.comparison.kept
            cycles = [(here.expected, here.actual), *((row.expected, row.actual) for row in after)]
            renames = propose_renames((kept(want), kept(got)) for want, got in cycles)
        return dataclasses.replace(divergence, context=context, proposed_renames=renames)


class Follower:
    """Follows replay past the first divergence, as an observer of the replay session:
    up to ``limit`` cycles (None: the rest of the log, where the divergence is
    ``suspect`` of a renamed behavior) as ``row`` writes them, none past one that
    replay cannot go on past."""

    def __init__(
        self, row: Callable[[CycleOutcome], ContextRow], limit: int | None, suspect: bool
    ) -> None:
        self._row, self._limit, self.suspect = row, limit, suspect
        self.rows: list[ContextRow] = []
        self.replaying = self.reading = limit != 0

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        """Take the next cycle past the divergence."""
        if outcome is None or outcome.changes is None or outcome.failure is not None:
            self.suspect = self.replaying = self.reading = False
            return
        self.rows.append(self._row(outcome))
        self.replaying = self.reading = len(self.rows) != self._limit


def propose_renames(
    cycles: Iterable[tuple[Sequence[StateChange], Sequence[StateChange]]],
) -> dict[str, str]:
    """The behavior rename map (old → new) that turns every expected cycle into the actual.

    ``cycles`` pairs each cycle's expected state changes with the actual ones. The
    substitution of behavior names must hold across all of them and be one-to-one; a
    state may differ only where it names a renamed behavior (an arbiter's winner).
    Returns an empty map when the traces differ in any other way, or not at all.
    """
    forward: dict[str, str] = {}
    backward: dict[str, str] = {}
    states: set[tuple[str, str]] = set()
    encode = msgspec.msgpack.encode
    for expected, actual in cycles:
        if len(expected) != len(actual):
            return {}
        for want, got in zip(expected, actual, strict=True):
            old, new = want.behavior, got.behavior
            if forward.setdefault(old, new) != new or backward.setdefault(new, old) != old:
                return {}
            for before, after in ((want.before, got.before), (want.after, got.after)):
                if isinstance(before, str) and isinstance(after, str):
                    if before != after:
                        states.add((before, after))
                elif encode(before) != encode(after):
                    return {}
    if any(forward.get(old) != new for old, new in states):
        return {}
    return {old: new for old, new in forward.items() if old != new}


def _unapproved(unapproved: UnapprovedDraw) -> tuple[DivergenceKind, str, str]:
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
    baseline = f"which the approved baseline does not hold{' in this cycle' if elsewhere else ''}"
    if recorded is None:
        message = f"{behavior} called {asked}, a draw the recording does not have, {baseline}"
        return DivergenceKind.RANDOM_OVERDRAWN, message, behavior
    if asked is None:
        message = f"{behavior} did not draw the recorded {recorded}, {baseline}"
        return DivergenceKind.RANDOM_UNDERDRAWN, message, behavior
    message = f"{behavior} called {asked} where {recorded} was recorded, {baseline}"
    return DivergenceKind.RANDOM_MISMATCH, message, behavior
