"""The verdict (the paper's Algorithm 2): replay a system on a session log and judge it.

Each cycle advances a simulated clock by HB_t, loads RS_t, updates the behaviors with RN_t
as their random numbers and compares their state changes and outputs with the recorded
ones: byte for byte first (the replay core), and only where the bytes differ by the
spec's comparison, which takes a cycle's state changes as a set. The first cycle that
still differs, unless only as an approved baseline allows, is written up as the
divergence: its kind and message, the robot state and draws, the cycles around it, and
the rename map when the behaviors differ only by a consistent renaming.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import os
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import msgspec

from beatlog.errors import EmptyCheckError
from beatlog.log.format import CycleRecord, StateChangeRecord, payload_encoder
from beatlog.log.payload import decode_outputs, decode_part
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.log.recording import LogSource
from beatlog.model.behavior import System
from beatlog.model.invariant import Invariant
from beatlog.model.perception import Perception, PerceptionTypeError
from beatlog.model.setup import SystemFactory
from beatlog.project.config import vouched_system
from beatlog.project.usercode import load_perception, load_system, user_traceback
from beatlog.replaying.compare import Comparison, state_fields
from beatlog.replaying.core import CycleOutcome, Expected, Replayer
from beatlog.replaying.draws import DrawLedger, Unapproved
from beatlog.replaying.expectation import Expectation, ExpectedStream
from beatlog.replaying.expected import ExpectedRecords
from beatlog.replaying.fit.check import check_catalogue, check_state_fields, period_note
from beatlog.replaying.fit.migration import StateMigration
from beatlog.replaying.invariants import InvariantChecker
from beatlog.replaying.outcome import draw_reports
from beatlog.replaying.pins import PinChecker, rebuilt_otherwise
from beatlog.replaying.recorded_states import recorded_changes
from beatlog.replaying.session import BatchReader, Observer, ReplaySession, fields_read
from beatlog.replaying.setup import SetupDrawError
from beatlog.replaying.verdict import (
    Checked,
    ContextRow,
    Divergence,
    DivergenceKind,
    FieldDifference,
    ReplayResult,
    StateChange,
    log_ended,
    reproduce_command,
)
from beatlog.replaying.window import Window

__all__ = ["NO_SAMPLES", "CycleJudge", "Follower", "propose_renames", "recorded_system", "replay"]

NO_SAMPLES = (
    "perception not run: the log holds no samples (record with --log-samples); "
    "its recorded robot states were replayed"
)
"""The note on a replay given a perception step for a log recorded without samples."""


def replay(
    log: LogSource,
    system: System | SystemFactory | str | None = None,
    *,
    keep_going: bool = False,
    allow_truncated: bool = False,
    allow_empty: bool = False,
    context_cycles: int = 5,
    comparison: Comparison | None = None,
    expected: Expectation | ExpectedStream | None = None,
    explain: bool = True,
    perception: Perception | str | None = None,
    break_at: int | None = None,
    observe: Callable[[CycleOutcome], object] | None = None,
    observers: Sequence[Callable[[SessionLogReader], Observer]] = (),
    readers: Sequence[Callable[[SessionLogReader], BatchReader]] = (),
    migration: StateMigration | None = None,
    start_cycle: int = 0,
    end_cycle: int | None = None,
    fresh_start: bool = False,
    invariants: Sequence[Invariant | type | str] = (),
    where: Path | None = None,
) -> ReplayResult:
    """Replay ``log`` against ``system`` (a system, a factory that builds one, or a
    ``module:factory`` reference; by default the one the log's header records, see
    :func:`recorded_system`) and judge it.

    A factory is handed the recorded set-up draws (:mod:`beatlog.model.setup`); drawing
    otherwise there is a divergence of kind
    :attr:`~beatlog.replaying.verdict.DivergenceKind.SETUP`, and a log with set-up draws
    refuses a system already built.

    Replay stops at the first divergence unless ``keep_going``, which replays every
    cycle and counts those that diverge. A truncated log fails with a LOG_ENDED
    divergence unless ``allow_truncated``. The divergence shows up to
    ``context_cycles`` cycles either side of it. A replay that checked nothing (no
    state change, output, draw or sample: :class:`~beatlog.replaying.verdict.Checked`)
    is no pass: it raises :class:`~beatlog.errors.EmptyCheckError` unless
    ``allow_empty``.

    ``comparison`` says what counts as the same (renames, ignored behaviors and output
    fields, tolerances; exact by default). ``expected`` is an approved baseline to judge
    against instead of the recording (read alongside the log when it is an
    :class:`~beatlog.replaying.expectation.ExpectedStream`): its state changes, outputs,
    approved draws and pinned robot states; the recording's heartbeats, robot states and
    random numbers are still replayed. Given a ``module:factory`` reference and
    ``explain``, the divergence names the robot-state fields the behaviors read in its
    cycle (one more replay, of a fresh system). The result's reproduce command replays
    with these options but ``comparison`` and ``expected``, which a spec carries.

    ``perception`` (a perception step, or a ``module:factory`` that builds one) turns on
    sensor-level replay when the log holds samples: RS_t is rebuilt from each cycle's
    samples and compared with the recorded one within the comparison's robot-state
    tolerances (a PERCEPTION divergence otherwise), and the behaviors run on it.
    ``break_at`` stops in the debugger (``breakpoint()``) just before the behaviors
    update in that cycle. ``observe`` is given every cycle's outcome up to the one that
    stops replay, and so are the observers (:class:`~beatlog.replaying.session.Observer`)
    that ``observers`` build from the opened log, so that a report is gathered in the
    verdict's own replay; ``readers`` build readers of its batches as recorded
    (:class:`~beatlog.replaying.session.BatchReader`), which take the whole log.
    ``migration`` maps robot-state fields renamed or retyped since the recording
    (:mod:`beatlog.replaying.fit.migration`). A log recorded at another heartbeat
    period than the system declares replays with a note saying so.

    ``invariants`` (:mod:`beatlog.model.invariant`: callables, classes instantiated afresh,
    or ``module:attribute`` references to either) are checked in every cycle whose
    update completes: the first that does not hold (or raises) is an INVARIANT
    divergence of its cycle, its headline where the cycle also differs.

    ``start_cycle`` and ``end_cycle`` (both inclusive) narrow the verdict to a window
    (:mod:`beatlog.replaying.window`): the cycles before it are replayed as recorded,
    and fail the replay only where it cannot go on past them; none after it is read,
    and the result counts the window's cycles alone, without a status. With
    ``fresh_start`` the behaviors start from rest at ``start_cycle`` instead, at its
    recorded cycle number and robot time, their state changes there found against the
    recorded states. A window past the log's last cycle is an error of ``where`` (the
    spec that set it; by default the log).

    :raises beatlog.errors.LogError: the log is missing, foreign, corrupt or does not fit
        the system's robot state type (see :mod:`beatlog.replaying.fit`).
    :raises beatlog.errors.FieldError: a robot-state tolerance names a field the recorded
        robot state lacks.
    :raises beatlog.errors.EmptyCheckError: nothing differed, but nothing was checked.
    :raises beatlog.errors.WindowError: the window starts or ends past the log's last
        cycle.
    """
    if system is None:
        system = recorded_system(Path(log))
    reference = system if isinstance(system, str) else None
    if reference is not None:
        system = functools.partial(load_system, reference)
    perception_reference = perception if isinstance(perception, str) else None
    if perception_reference is not None:
        perception = load_perception(perception_reference)
    comparison = comparison or Comparison()
    migration = migration or StateMigration()
    if isinstance(expected, Expectation):
        expected = expected.stream()
    window = Window(start_cycle, end_cycle, fresh=fresh_start)
    named = [invariant for invariant in invariants if isinstance(invariant, str)]
    started = time.perf_counter()  # the replay's wall time counts opening and checking the log

    def reproduce(recorded: str) -> str:
        return reproduce_command(
            "replay",
            os.fspath(log),
            "--system",
            reference or recorded or "MODULE:FACTORY",
            *(["--perception", perception_reference] if perception_reference else []),
            *(["--keep-going"] if keep_going else []),
            *(["--allow-truncated"] if allow_truncated else []),
            *(["--allow-empty"] if allow_empty else []),
            *migration.arguments(),
            *window.arguments(),
            *(["--invariants", ",".join(named)] if named else []),
        )

    try:
        session = ReplaySession(
            log,
            system,  # type: ignore[arg-type]  # a reference is a factory by now
            perception=perception,  # type: ignore[arg-type]  # likewise built by now
            break_at=break_at,
            migration=migration,
            living=expected is not None,
            rename=comparison.rename,
            state_pins=None if expected is None else PinChecker(pinned=expected.pinned),
            fresh_from=window.fresh_from,
        )
    except SetupDrawError as diverged:  # no cycle replayed
        at_setup = Divergence(kind=diverged.kind, cycle=0, time_ns=0, message=diverged.problem)
        wall = time.perf_counter() - started
        reproduced = reproduce(diverged.recorded_system)
        return ReplayResult(Path(log), False, 0, Checked(), 0, wall, None, at_setup, 1, reproduced)
    with session:
        reader = session.reader
        check_state_fields(
            reader.header,
            comparison.state_tolerance,
            reader.path,
            "robot-state tolerance for",
            migration,
        )
        assert session.replayer is not None  # a session with a system replays
        replayer = session.replayer
        checker = InvariantChecker(invariants, replayer.system) if invariants else None
        judge = CycleJudge(
            replayer,
            comparison=comparison,
            expected=expected,
            window=window,
            invariants=checker,
            keep_going=keep_going,
            context=context_cycles,
        )
        watching = [factory(reader) for factory in observers]
        if observe is not None:
            watching.append(_Calling(observe))
        if replayer.perception is None and not watching:
            # State-level replay without observers needs RS_t decoded, and only that:
            # decoded with each batch, it is read once (the log fits: checked above).
            reader.decode_states(replayer.state_type)
        session.run(watching, judge=judge, readers=[factory(reader) for factory in readers])
        status = None if window.closed else reader.status
        judge.end(status, where or reader.path, allow_truncated=allow_truncated)
        wall = time.perf_counter() - started
    divergence, checked = judge.divergence, judge.checked
    if setup_draws := reader.header.drawn_at_setup():  # the factory drew them as recorded
        checked = dataclasses.replace(checked, draws=checked.draws + len(setup_draws))
    if divergence is None and not allow_empty and not checked.anything:
        raise EmptyCheckError(reader.path, _nothing_checked(judge.cycles))
    if explain and reference and divergence and divergence.kind is not DivergenceKind.LOG_ENDED:
        factory = functools.partial(load_system, reference)
        read = fields_read(
            log, factory, divergence.cycle, migration=migration, fresh_from=window.fresh_from
        )
        divergence = dataclasses.replace(divergence, fields_read=read)
    no_samples = NO_SAMPLES if perception is not None and replayer.perception is None else ""
    notes = (period_note(reader.header, replayer.system), no_samples, window.note())
    return ReplayResult(
        log=Path(log),
        ok=divergence is None,
        cycles=judge.cycles,
        checked=checked,
        robot_time_ns=judge.robot_time_ns,
        wall_time_s=wall,
        status=status,
        divergence=divergence,
        divergent_cycles=judge.divergent_cycles,
        reproduce=reproduce(reader.header.system),
        notes=tuple(note for note in notes if note),
    )


class CycleJudge:
    """The verdict as a replay session's :class:`~beatlog.replaying.session.Judge`: judges
    the cycles that do not agree at once (:meth:`judge`, the hot path) and writes up the
    first divergence, with up to ``context`` cycles either side, counting those that
    diverge.

    ``expected`` is an approved baseline to judge against instead of the recording.
    ``invariants`` are checked in every cycle that completes (none then agrees at once).
    The cycles before ``window`` must only let replay go on. Past the divergence where
    it stops, a :class:`Follower` gathers what happened next.
    """

    def __init__(
        self,
        replayer: Replayer,
        *,
        comparison: Comparison,
        expected: ExpectedStream | None,
        window: Window,
        invariants: InvariantChecker | None,
        keep_going: bool,
        context: int,
    ) -> None:
        header, self.path, self.executor = replayer.header, replayer.path, replayer.executor
        check_catalogue(header, replayer.system, self.path, comparison.renames)
        names = self.executor.behavior_ids
        replayer.random.expect_actors(header.behaviors, names, comparison.rename)
        self.replayer, self.comparison, self.window = replayer, comparison, window
        self._invariants, self._keep_going, self.context = invariants, keep_going, context
        self._encoder = payload_encoder()
        self._pins = replayer.state_pins if replayer.perception is not None else None
        self._expected = None
        self.expected_names = list(header.behaviors)
        self._ledger = None if expected is None else DrawLedger(expected.draws)
        """The draws the approved baseline approves."""
        if expected is not None:
            self._expected = ExpectedRecords(
                expected, header.behaviors, comparison.rename, self._pins
            )
            self.expected_names = self._expected.names
        departs = expected is not None and expected.departs
        self._against = "the approved baseline" if departs else "the recording"
        self._batches: deque[Sequence[CycleRecord]] = deque(maxlen=context + 1)
        """The last batches: they hold the cycles before a divergence (none is empty)."""
        self._rows_before: list[ContextRow] = []
        self.divergence: Divergence | None = None
        """The first divergence, if any."""
        self.divergent_cycles = 0
        self.judging = True
        """Whether it still judges cycles: it has not stopped at a divergence."""
        self._stopped: tuple[int, int, int] | None = None  # cycle, robot time, samples
        self._follower: Follower | None = None
        self._counted = [0, 0, 0, 0]
        """State changes, outputs and draws of the cycles that agreed here (those that
        agreed at once the replay core counts), and samples of those that diverged."""
        self.cycles = self.robot_time_ns = 0
        """Cycles and robot time judged, from the window's start up to the divergence
        that stopped replay, or to the end: known at :meth:`end`, with :attr:`checked`."""
        self.checked = Checked()
        at: dict[str, int] = {}
        for position, name in enumerate(self.expected_names):
            at.setdefault(comparison.rename(name), position)
        replayer.expect(
            Expected(
                None if names == self.expected_names else [at.get(name, -1) for name in names],
                self._encoder,
                invariants is not None,
                None if self._ledger is None else self._ledger.approves,
            )
        )

    def batches(self, batches: Iterator[Sequence[CycleRecord]]) -> Iterator[Sequence[CycleRecord]]:
        """The log's batches, with an approved baseline's state changes and outputs in
        place of the recorded ones and cut by the window; each kept, for the cycles
        before a divergence, as it is handed on."""
        if self._expected is not None:
            first = self.executor.context.cycle + 1  # 0, or a fresh start's cycle
            batches = self._expected.batches(batches, self.path, first)
        for batch in self.window.batches(batches, self.replayer):
            self._batches.append(batch)
            yield batch

    def judge(
        self,
        index: int,
        record: CycleRecord,
        changes: list[StateChangeRecord] | None,
        outcome: CycleOutcome | None,
    ) -> Follower | None:
        """Judge a cycle that did not agree at once, the ``index``-th of its batch: it
        agrees when it went cleanly (or only as an approved baseline lets it differ) and
        its state changes and outputs match by the :class:`Comparison`, and every
        invariant holds. A cycle before the window fails only where replay cannot go on
        past it."""
        replayer = self.replayer
        if self.executor.context.cycle < self.window.start:
            if changes is not None:
                return None
            outcome = outcome or replayer.outcome()
            return None if replayer.stop(outcome) is None else self._stop(index, outcome, None)
        if changes is None:
            outcome = outcome or replayer.outcome()  # judged by its robot state, then as usual
            changes = outcome.changes if self._agrees_but_for_pins(outcome) else None
        agrees, unloggable = False, None
        if changes is not None:
            outputs = self.executor.context.outputs
            compare = self.comparison
            try:
                agrees = replayer.agrees(record, changes) or (
                    compare.changes_agree(self._named(record.state_changes), self._actual(changes))
                    and compare.outputs_agree(self._expected_outputs(record.outputs), outputs)
                )
            except (TypeError, ValueError, msgspec.EncodeError) as exc:  # cannot be logged
                unloggable = exc
            if agrees:
                self._counted[0] += len(changes)
                self._counted[1] += len(outputs)
                self._counted[2] += len(replayer.random.recorded)  # it drew them all
                if self._invariants is None:
                    return None
        outcome = outcome or replayer.outcome()
        if unloggable is not None:
            outcome = outcome._replace(failure=unloggable)
        # In a cycle that differs, an invariant that does not hold is the headline: it
        # says what is wrong, where the difference says only that something changed.
        violation = None if self._invariants is None else self._invariants.check(outcome)
        return None if agrees and violation is None else self._stop(index, outcome, violation)

    def _stop(
        self, index: int, outcome: CycleOutcome, violation: Divergence | None
    ) -> Follower | None:
        """Write up a cycle that diverged (``violation``: an invariant that did not hold
        in it) and, unless told to keep going, stop judging there."""
        self.divergent_cycles += 1
        self._counted[3] += len(outcome.samples)
        if self.divergence is None:
            self.divergence = divergence = self._write_up(outcome, violation)
            *earlier, last = self._batches
            recent = [*itertools.chain(*earlier), *last[: index + 1]][-(self.context + 1) :]
            time_ns = divergence.time_ns
            for offset in range(1, len(recent)):
                time_ns -= recent[-offset].heartbeat_ns
                if expected := tuple(self._named(recent[-offset - 1].state_changes)):
                    row = ContextRow(divergence.cycle - offset, time_ns, expected, expected)
                    self._rows_before.insert(0, row)
        if self._keep_going:
            return None
        self.judging = False
        self._stopped = (outcome.cycle + 1, outcome.time_ns, self.replayer.samples_perceived)
        assert self.divergence is not None  # written up above
        rename = self.comparison.rename
        suspect = self.divergence.kind is DivergenceKind.STATE_CHANGES and not {
            rename(name) for name in self.expected_names
        } <= set(self.executor.behavior_ids)
        self._follower = Follower(self._row, None if suspect else self.context, suspect)
        return self._follower

    def end(self, status: LogStatus | None, where: Path, *, allow_truncated: bool) -> None:
        """Take the end of the session: count what was judged, write the cycles around
        the divergence into it, and judge how the log ended (``status``,
        see :meth:`~beatlog.replaying.window.Window.ended_early`)."""
        context = self.executor.context
        cycle, time_ns, samples = self._stopped or (
            context.cycle + 1,
            context.time_ns,
            self.replayer.samples_perceived,
        )
        window = self.window
        changes, outputs, draws, samples_before = window.before
        agreed = self.replayer.agreed
        self.cycles = max(0, cycle - window.start)
        self.robot_time_ns = max(0, time_ns - window.start_ns)
        self.checked = Checked(
            agreed[0] - changes + self._counted[0],
            agreed[1] - outputs + self._counted[1],
            agreed[2] - draws + self._counted[2],
            samples - samples_before - self._counted[3],
        )
        self._write_context()
        if self.judging and window.ended_early(status, where, allow_truncated=allow_truncated):
            assert status is not None  # a log that ended early says how
            self.divergent_cycles += 1
            self.divergence = self.divergence or log_ended(status, cycle, time_ns)

    def _write_context(self) -> None:
        """Write the cycles around the divergence into it, and the rename map the rest
        of the log proposes where it looked like a renamed behavior."""
        divergence, follower = self.divergence, self._follower
        if divergence is None:
            return
        here = ContextRow(
            divergence.cycle, divergence.time_ns, divergence.expected, divergence.actual
        )
        after = [] if follower is None else follower.rows[: self.context]
        context_rows = (
            *self._rows_before,
            here,
            *(row for row in after if row.expected or row.actual),
        )
        renames: dict[str, str] = {}
        if follower is not None and follower.suspect:
            kept = self.comparison.kept
            cycles = [(divergence.expected, divergence.actual)]
            cycles.extend((row.expected, row.actual) for row in follower.rows)
            renames = propose_renames((kept(want), kept(got)) for want, got in cycles)
        self.divergence = dataclasses.replace(
            divergence, context=context_rows, proposed_renames=renames
        )

    def _write_up(self, outcome: CycleOutcome, violation: Divergence | None) -> Divergence:
        """The divergence of a cycle: what was expected of it beside what it saw, headed
        by why it differs (an invariant's ``violation``, if any)."""
        record = outcome.record
        expected = tuple(self._named(record.state_changes))
        expected_outputs = self._expected_outputs(record.outputs)
        recorded = tuple(draw_reports(outcome.recorded_draws, self.replayer.header.behaviors))
        if violation is not None:
            return dataclasses.replace(
                violation,
                expected=expected,
                expected_outputs=expected_outputs,
                random_recorded=recorded,
            )
        actual = tuple(self._actual(outcome.changes or []))
        failure, trace, behavior = outcome.failure, None, None
        perceiving = self.replayer.perception is not None and outcome.perception_failure is None
        differences = self._state_differences(outcome) if perceiving else ()
        stop = self.replayer.stop(outcome)
        ledger, draws = self._ledger, outcome.draw_differences or ()
        unapproved = None if ledger is None else ledger.check(outcome.cycle, draws)
        compare = self.comparison
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
        elif not compare.changes_agree(expected, actual):
            # The first behavior difference is the headline, even when the changed
            # behavior then drew fewer random numbers than were recorded.
            kind = DivergenceKind.STATE_CHANGES
            message = f"behavior state changes differ from {self._against}"
            behavior = compare.first_differing_behavior(expected, actual)
            if stop is not None:
                message += f", and then the behaviors {stop.message}"
        elif stop is not None:
            kind, message, behavior = stop
        elif unapproved is not None:
            kind, message, behavior = _unapproved(unapproved)
        else:
            kind, message = DivergenceKind.OUTPUTS, f"outputs differ from {self._against}"
        if kind is not DivergenceKind.STATE_CHANGES and compare.only_order_differs(
            expected, actual
        ):
            message += (
                "; the state changes differ only in the order behaviors are listed,"
                " which is no difference"
            )
        if outcome.cycle < self.window.start:
            message = f"before the window (cycle {self.window.start} on): {message}"
        completed = failure is None and outcome.draw_problem is None
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
            random_drawn=tuple(draw_reports(outcome.drawn, self.executor.behavior_ids)),
            traceback=trace,
            perception=differences,
            samples=tuple((sample.sensor, sample.value) for sample in outcome.samples),
        )

    def _state_differences(self, outcome: CycleOutcome) -> tuple[FieldDifference, ...]:
        """The robot-state fields perception rebuilt otherwise than expected, beyond their
        tolerance: expected is the recorded RS_t, or in a cycle an approved baseline pins,
        its digest (then the fields named are those that differ from the recording now or
        did in the baseline's run of cycles)."""
        expected, actual = state_fields(outcome.recorded_state), state_fields(outcome.state)
        pins = self._pins
        if pins is None or outcome.cycle not in pins:
            named = set(self.comparison.state_differences(expected, actual))
        elif pins.found(outcome.cycle, self._state_bytes(outcome.state)) is None:
            return ()
        else:
            named = {*pins.run_at(outcome.cycle).fields, *rebuilt_otherwise(expected, actual)}
        return tuple(
            FieldDifference(name, expected.get(name), actual.get(name))
            for name in dict.fromkeys([*expected, *actual])
            if name in named
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
        pins = self._pins
        if pins is None or outcome.cycle not in pins:
            names = ", ".join(d.field for d in differences)
            against = " from the approved baseline" if pins and pins.pinned else ""
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

    def _agrees_but_for_pins(self, outcome: CycleOutcome) -> bool:
        """Whether a cycle the core did not call clean went cleanly but for what the
        approved baseline allows: perception rebuilt the robot state as expected, and
        the draws made otherwise than recorded are ones it approves (using them up)."""
        if not outcome.completed or outcome.perception_failure is not None:
            return False
        perceived = self.replayer.perception is not None and outcome.perception_differs
        if perceived and self._state_differences(outcome):
            return False
        differences = outcome.draw_differences
        if self._ledger is None:
            return not differences
        return self._ledger.check(outcome.cycle, differences or ()) is None

    def _expected_outputs(self, raw_outputs: msgspec.Raw) -> dict[str, Any]:
        cycle = self.executor.context.cycle
        return decode_part(self.path, raw_outputs, decode_outputs, "outputs", cycle)

    def _named(self, raw_changes: msgspec.Raw) -> list[StateChange]:
        """Expected state changes in current names.

        :raises beatlog.errors.CorruptLogError: one names a behavior the catalogue lacks.
        """
        names, renamed = self.expected_names, self.comparison.renamed
        cycle = self.executor.context.cycle
        recorded = recorded_changes(self.path, raw_changes, cycle, len(names))
        return [
            renamed(StateChange(names[index], before, after)) for index, before, after in recorded
        ]

    def _actual(self, changes: list[StateChangeRecord]) -> list[StateChange]:
        """State changes the behaviors made, by name."""
        names = self.executor.behavior_ids
        return [StateChange(names[index], before, after) for index, before, after in changes]

    def _row(self, outcome: CycleOutcome) -> ContextRow:
        """A cycle replayed past the divergence, as its context shows it."""
        expected = tuple(self._named(outcome.record.state_changes))
        return ContextRow(
            outcome.cycle, outcome.time_ns, expected, tuple(self._actual(outcome.changes or []))
        )


class Follower:
    """Follows replay past the first divergence, as an observer of the replay session:
    up to ``limit`` cycles (None: the rest of the log, where the divergence is
    ``suspect`` of a renamed behavior) as ``row`` writes them, up to one replay cannot
    go on past."""

    def __init__(
        self, row: Callable[[CycleOutcome], ContextRow], limit: int | None, suspect: bool
    ) -> None:
        self._row, self._limit, self.suspect = row, limit, suspect
        self.rows: list[ContextRow] = []
        self.replaying = self.reading = limit != 0

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        """Take the next cycle past the divergence."""
        if not self.reading or outcome is None:
            return
        if outcome.changes is None or outcome.failure is not None:
            self.suspect = self.replaying = self.reading = False
            return
        self.rows.append(self._row(outcome))
        self.replaying = self.reading = len(self.rows) != self._limit


class _Calling:
    """An ``observe`` callback as an observer: given every outcome."""

    replaying = reading = True

    def __init__(self, observe: Callable[[CycleOutcome], object]) -> None:
        self._observe = observe

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        if outcome is not None:
            self._observe(outcome)


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
    baseline = f"which the approved baseline does not hold{' in this cycle' if elsewhere else ''}"
    if recorded is None:
        message = f"{behavior} called {asked}, a draw the recording does not have, {baseline}"
        return DivergenceKind.RANDOM_OVERDRAWN, message, behavior
    if asked is None:
        message = f"{behavior} did not draw the recorded {recorded}, {baseline}"
        return DivergenceKind.RANDOM_UNDERDRAWN, message, behavior
    message = f"{behavior} called {asked} where {recorded} was recorded, {baseline}"
    return DivergenceKind.RANDOM_MISMATCH, message, behavior


def _nothing_checked(cycles: int) -> str:
    """Why a replay that found no difference is no pass: it compared nothing."""
    what = (
        f"{cycles} cycle{'' if cycles == 1 else 's'} but no state change, output, draw or sample"
        if cycles
        else "0 cycles"
    )
    return (
        f"the replay checked nothing ({what}); if nothing is meant to happen in it, "
        "accept it with --allow-empty (in a spec: allow_empty = true)"
    )


def recorded_system(log: str | Path, *, project: Path | None = None) -> str:
    """The system reference the log's header records (``beatlog record --system-ref``),
    once the project vouches for it: bytes from a log never choose code on their own.

    ``project`` is a folder of the project whose ``[tool.beatlog] systems`` must list
    the reference (the working directory by default; a spec's folder for a spec), see
    :func:`beatlog.project.config.vouched_system`.

    :raises beatlog.errors.SystemLoadError: the log records none, or one the project
        does not list.
    """
    with SessionLogReader(log) as reader:
        reference = reader.header.system
    return vouched_system(log, reference, project=Path.cwd() if project is None else project)
