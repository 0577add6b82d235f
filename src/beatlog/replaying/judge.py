"""The replay engine (the paper's Algorithm 2): run a system on a session log and judge it.

For each cycle t it advances a simulated clock by HB_t (never waiting), loads RS_t,
updates the behaviors with RN_t as their random numbers and compares the behavior
state changes and outputs with the recorded ones: byte for byte first (the replay
core), and only when the bytes differ by the spec's comparison, which takes a cycle's
state changes as a set. A cycle that still differs, unless only as an approved
baseline lets it (robot states it pins, draws it approves), is written up as the first
divergence: its kind, the message naming the behavior and call, the robot-state fields
and draws, the cycles around it, and the rename map when the behaviors differ from
those expected only by a consistent renaming.
"""

from __future__ import annotations

import dataclasses
import functools
import os
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import msgspec

from beatlog.errors import CorruptLogError, EmptyCheckError
from beatlog.log.format import CycleRecord, StateChangeRecord, payload_encoder
from beatlog.log.payload import decode_outputs, decode_part, decode_state_changes
from beatlog.log.reader import SessionLogReader
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
from beatlog.replaying.session import (
    BatchReader,
    Observer,
    ReplaySession,
    check_window,
    fields_read,
    through,
)
from beatlog.replaying.setup import SetupDrawError
from beatlog.replaying.verdict import (
    Checked,
    ContextRow,
    Divergence,
    DivergenceKind,
    FieldDifference,
    ReplayResult,
    StateChange,
    reproduce_command,
)

__all__ = ["NO_SAMPLES", "CycleJudge", "Follower", "propose_renames", "recorded_system", "replay"]

_ENCODE = msgspec.msgpack.encode

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
    ``module:factory`` reference; by default the reference recorded in the log's
    header, see :func:`recorded_system`).

    A factory (a reference names one) builds the system once the header is read: one
    that takes ``random`` is handed the recorded set-up draws
    (:mod:`beatlog.model.setup`), and drawing otherwise fails with a divergence of kind
    :attr:`~beatlog.replaying.verdict.DivergenceKind.SETUP`. A log with set-up draws
    needs a factory: a system already built is refused.

    Stops at the first divergence unless ``keep_going`` is set, in which case it
    replays every cycle and counts the ones that diverged. A truncated log fails
    with a LOG_ENDED divergence after its last complete cycle unless
    ``allow_truncated`` is set. The divergence carries the state changes of up to
    ``context_cycles`` cycles before and after it. The result counts what was checked
    (:class:`~beatlog.replaying.verdict.Checked`); a replay that checked nothing (no
    cycle, or no state change, output, random draw or sample in any) is no pass: it
    raises :class:`~beatlog.errors.EmptyCheckError` unless ``allow_empty`` is set.

    ``comparison`` says what counts as the same (renames, ignored behaviors and output
    fields, tolerances; exact by default). ``expected`` is an approved baseline to judge
    against instead of the recording (read alongside the log, a part at a time, when
    it is an :class:`~beatlog.replaying.expectation.ExpectedStream`): its state changes,
    and its outputs when it pins them (else the recorded outputs); the recording's
    heartbeats, robot states and random numbers are still used (and in sensor-level
    replay, the robot states it pins instead of the recorded ones). When the behaviors
    differ from what was expected only by a consistent renaming, the divergence
    proposes the rename map. Given a ``module:factory`` reference and ``explain``, the
    divergence also names the robot-state fields the behaviors read in that cycle (one
    more replay, of a fresh system; a suite gathers them with its other details
    instead). The result's
    reproduce command replays with these options, except ``comparison`` and
    ``expected``, which a spec carries (see :func:`beatlog.suite.run_spec`).

    ``perception`` (a perception step, or a ``module:factory`` that builds one) turns on
    sensor-level replay when the log holds samples: RS_t is rebuilt from each cycle's
    samples and compared with the recorded one, field by field within the comparison's
    robot-state tolerances (a PERCEPTION divergence names the fields that differ and the
    samples), and the behaviors run on the rebuilt state, tolerated differences and all.
    ``break_at`` stops in the debugger (``breakpoint()``, honouring ``PYTHONBREAKPOINT``)
    just before the behaviors update in that cycle. ``observe`` is given every cycle's
    outcome up to the first divergence (the one that stops replay included), and
    ``observers`` build, from the opened log, observers
    (:class:`~beatlog.replaying.session.Observer`, e.g. a
    :class:`~beatlog.analysis.timeline.TimelineCollector`) that take the same cycles, so
    that a report is gathered in the verdict's own replay; ``readers`` build readers of
    its batches as recorded (:class:`~beatlog.replaying.session.BatchReader`, e.g. a
    :class:`~beatlog.analysis.recorded.RecordedChanges` for the coverage), which take
    the whole log. ``migration`` maps robot-state fields renamed or retyped since the
    recording onto the system's (:mod:`beatlog.replaying.fit.migration`); the reproduce
    command carries it. A log recorded at another heartbeat period than the system
    declares replays with a note saying so
    (:func:`~beatlog.replaying.fit.check.period_note`).

    ``invariants`` (:mod:`beatlog.model.invariant`: callables, classes instantiated afresh
    for this replay, or ``module:attribute`` references to either) are checked in every
    cycle whose update completes, open-loop stretches against an approved baseline
    included: the first that does not hold (or whose own code raises) is an INVARIANT
    divergence of its cycle, unless a divergence came in an earlier cycle (in the same
    cycle, the invariant is the headline). The reproduce command carries the
    references.

    ``start_cycle`` and ``end_cycle`` (both inclusive) narrow the verdict to a window of
    cycles: the cycles before ``start_cycle`` are replayed as recorded, to rebuild the
    behaviors' state, and are not judged, except that replay must be able to go on past
    each (a behavior that raises there, or cannot draw as recorded, fails the replay
    "before the window"); replay stops after ``end_cycle``, and the rest of the log is
    not read (the part read is checked as ever). The result then counts the window's
    cycles alone, and has no status: the log's end was not read. A window past the
    log's last cycle is an error of ``where`` (the spec that set it; by default the log).
    With ``fresh_start`` the behaviors start from rest at ``start_cycle`` instead: the
    system is built as for the log's start and first updates in ``start_cycle``, at its
    recorded cycle number and robot time, and the cycles before it are not replayed,
    only read as far as checking the log needs
    (:class:`~beatlog.replaying.session.ReplaySession`); a behavior's state there is
    its initial one, not the recording's, and its state changes are found against the
    recorded states, so that one whose fresh state is not the recorded one differs
    there.

    :raises beatlog.errors.LogError: the log is missing, foreign, corrupt or its robot
        state does not fit the system's robot state type (see :mod:`beatlog.replaying.fit`).
    :raises beatlog.errors.FieldError: a robot-state tolerance names a field the recorded
        robot state lacks.
    :raises beatlog.errors.EmptyCheckError: the replay found no difference, but checked
        nothing either, and ``allow_empty`` is not set.
    :raises beatlog.errors.WindowError: the window starts or ends past the log's last
        cycle.
    """
    if system is None:
        system = recorded_system(Path(log))
    reference = system if isinstance(system, str) else None
    if isinstance(system, str):
        system = functools.partial(load_system, system)
    perception_reference = perception if isinstance(perception, str) else None
    if isinstance(perception, str):
        perception = load_perception(perception)
    comparison = comparison or Comparison()
    migration = migration or StateMigration()
    if isinstance(expected, Expectation):
        expected = expected.stream()
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
            *(["--start-cycle", str(start_cycle)] if start_cycle else []),
            *([] if end_cycle is None else ["--end-cycle", str(end_cycle)]),
            *(["--fresh-start"] if fresh_start and start_cycle else []),
            *_invariant_arguments(invariants),
        )

    try:
        session = ReplaySession(
            log,
            system,
            perception=perception,
            break_at=break_at,
            migration=migration,
            living=expected is not None,
            rename=comparison.rename,
            state_pins=None if expected is None else PinChecker(pinned=expected.pinned),
            fresh_from=start_cycle if fresh_start else 0,
        )
    except SetupDrawError as diverged:
        wall = time.perf_counter() - started
        return _diverged_at_setup(Path(log), diverged, wall, reproduce(diverged.recorded_system))
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
        built = session.replayer.system
        judge = CycleJudge(
            session.replayer,
            keep_going=keep_going,
            context=context_cycles,
            comparison=comparison,
            expected=expected,
            start_cycle=start_cycle,
            end_cycle=end_cycle,
            invariants=InvariantChecker(invariants, built) if invariants else None,
        )
        watching = [_WhileJudging(factory(reader), judge) for factory in observers]
        if observe is not None:
            watching.append(_WhileJudging(_Calling(observe), judge))
        if judge.replayer.perception is None and not watching:
            # State-level replay without observers needs RS_t decoded, and only that:
            # decoded with each batch, it is read once (the log fits: checked above).
            reader.decode_states(judge.replayer.state_type)
        session.run(watching, judge=judge, readers=[factory(reader) for factory in readers])
        judge.end()
        status = None if judge.window_closed else reader.status
        if status is not None and judge.judging:
            if not status.complete and not allow_truncated:
                judge.log_ended(status.describe(), status.cycles)
            else:
                check_window(where or reader.path, status.cycles, start_cycle, end_cycle)
        wall = time.perf_counter() - started
    divergence = judge.divergence
    checked = judge.checked
    if setup_draws := reader.header.drawn_at_setup():  # the factory drew them as recorded
        checked = dataclasses.replace(checked, draws=checked.draws + len(setup_draws))
    no_samples = NO_SAMPLES if perception is not None and judge.replayer.perception is None else ""
    if divergence is None and not allow_empty and not checked.anything:
        raise EmptyCheckError(reader.path, _nothing_checked(judge.cycles))
    if (
        explain
        and divergence is not None
        and reference
        and divergence.kind is not DivergenceKind.LOG_ENDED
    ):
        factory = functools.partial(load_system, reference)
        read = fields_read(
            log, factory, divergence.cycle, migration=migration, fresh_from=session.fresh_from
        )
        divergence = dataclasses.replace(divergence, fields_read=read)
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
        notes=tuple(
            note
            for note in (
                period_note(reader.header, built),
                no_samples,
                _before(start_cycle, fresh=bool(session.fresh_from)),
            )
            if note
        ),
    )


def _diverged_at_setup(
    log: Path, diverged: SetupDrawError, wall: float, reproduce: str
) -> ReplayResult:
    """The verdict of a replay whose system drew otherwise at set-up: no cycle replayed."""
    return ReplayResult(
        log=log,
        ok=False,
        cycles=0,
        checked=Checked(),
        robot_time_ns=0,
        wall_time_s=wall,
        status=None,
        divergence=Divergence(kind=diverged.kind, cycle=0, time_ns=0, message=diverged.problem),
        divergent_cycles=1,
        reproduce=reproduce,
    )


def _before(start_cycle: int, *, fresh: bool) -> str:
    """The note on a window's cycles before it: replayed, not judged, not counted; or,
    from a fresh start, not replayed at all."""
    if not start_cycle:
        return ""
    cycles = f"{start_cycle} cycle{'' if start_cycle == 1 else 's'}"
    if fresh:
        start = f"fresh start: the behaviors start from rest at cycle {start_cycle}"
        return f"{start}; {cycles} before it not replayed"
    return f"{cycles} before the window replayed as recorded to rebuild the state, unjudged"


class CycleJudge:
    """Judges the cycles a replay session steps and writes up the first divergence, with
    up to ``context`` cycles either side, counting the cycles that diverge: the session's
    :class:`~beatlog.replaying.session.Judge`, whose :meth:`judge` is the hot path.

    ``expected`` is an approved baseline to judge against instead of the recording: its
    state changes and outputs, the draws it approves and the robot states it pins.
    ``invariants`` are checked in every cycle that completes (so none agrees at once:
    only a replay with invariants pays for every cycle's outcome); the first that does
    not hold is a divergence of its cycle, and the headline where the cycle also
    differs. Past the divergence where it stops, a :class:`Follower` gathers what
    happened next.
    It judges the cycles from ``start_cycle`` to ``end_cycle`` (both inclusive; None: to
    the log's end): the earlier ones must only let replay go on, and the log's batches
    end after ``end_cycle``.
    """

    def __init__(
        self,
        replayer: Replayer,
        *,
        keep_going: bool,
        context: int,
        comparison: Comparison,
        expected: ExpectedStream | None,
        start_cycle: int = 0,
        end_cycle: int | None = None,
        invariants: InvariantChecker | None = None,
    ) -> None:
        header, path = replayer.header, replayer.path
        self._invariants = invariants
        """What checks the invariants in each cycle that agrees; None: there are none."""
        self.comparison = comparison
        self.context = context
        """Cycles shown either side of the first divergence."""
        self._keep_going = keep_going
        self._start = start_cycle
        """The first cycle judged: those before it only rebuild the behaviors' state."""
        self._end = end_cycle
        """The last cycle judged and read; None: the log's last."""
        self._start_ns = 0  # robot time where the window starts
        self._before = (0, 0, 0, 0)
        """What the replay core counted before the window (state changes, outputs and
        draws of the cycles that agreed at once, samples perceived): not judged."""
        self.window_closed = False
        """Whether the log's batches stopped at the window's end, the rest unread."""
        self.path = path
        self.replayer = replayer
        check_catalogue(header, replayer.system, path, comparison.renames)
        replayer.random.expect_actors(
            header.behaviors, replayer.executor.behavior_ids, comparison.rename
        )
        self.executor = replayer.executor
        self._stopped_at: tuple[int, int] | None = None
        self._samples_perceived = 0
        """The replay core's count of samples perceived, where judging stopped or ended."""
        self._follower: Follower | None = None
        """What follows replay past the divergence where judging stopped."""
        self._encoder = encoder = payload_encoder()
        self._state_pins: PinChecker | None = (
            replayer.state_pins if replayer.perception is not None else None
        )
        self._expected = (
            None
            if expected is None
            else ExpectedRecords(expected, header.behaviors, comparison.rename, self._state_pins)
        )
        self.expected_names = (
            list(header.behaviors) if self._expected is None else self._expected.names
        )
        self._ledger = None if expected is None else DrawLedger(expected.draws)
        """The draws the approved baseline approves."""
        expected_at: dict[str, int] = {}
        for position, name in enumerate(self.expected_names):
            expected_at.setdefault(comparison.rename(name), position)
        expected_index = [expected_at.get(name, -1) for name in self.executor.behavior_ids]
        """Each behavior's index in the expected catalogue (-1: none there), for comparing
        the state changes as bytes when the catalogues differ."""
        departs = expected is not None and expected.departs
        self._against = "the approved baseline" if departs else "the recording"
        self._batches: deque[Sequence[CycleRecord]] = deque(maxlen=context + 1)
        """The last batches: they hold the cycles before a divergence (none is empty)."""
        self._recent: list[CycleRecord] = []
        """The cycles before the first divergence, then the divergence."""
        self.divergence: Divergence | None = None
        """The first divergence, if any."""
        self.divergent_cycles = 0
        """The cycles that diverged."""
        self._samples_diverged = 0
        self._changes_checked = self._outputs_checked = self._draws_checked = 0
        """The state changes, outputs and draws of the cycles that agreed here (those
        that agreed at once the replay core counts)."""
        replayer.expect(
            Expected(
                None if self.executor.behavior_ids == self.expected_names else expected_index,
                encoder,
                invariants is not None,
                None if self._ledger is None else self._ledger.approves,
            )
        )

    def batches(self, batches: Iterator[Sequence[CycleRecord]]) -> Iterator[Sequence[CycleRecord]]:
        """The log's batches, with an approved baseline's state changes and outputs in
        place of the recorded ones where it expects others; each kept for the cycles
        before a divergence as it is handed on. A batch is cut where the window starts,
        so that what the replay core counted before it is known, and where it ends,
        the last read."""
        first = self.executor.context.cycle + 1  # 0, or a fresh start's cycle
        if self._expected is not None:
            batches = self._expected.batches(batches, self.path, first)
        if self._start or self._end is not None:
            batches = self._windowed(batches, first)
        for batch in batches:
            self._batches.append(batch)
            yield batch

    def _windowed(
        self, batches: Iterator[Sequence[CycleRecord]], first: int
    ) -> Iterator[Sequence[CycleRecord]]:
        """``batches``, cycle ``first`` on, cut where the window starts and after it ends
        (none read after)."""
        for batch in through(batches, self._end, self._close, first):
            at, first = first, first + len(batch)
            if at < self._start < first:
                yield batch[: self._start - at]
                self._window_opens()
                yield batch[self._start - at :]
                continue
            if at == self._start > 0:
                self._window_opens()
            yield batch

    def _close(self) -> None:
        """The window's end is reached: the rest of the log is not read."""
        self.window_closed = True

    def _window_opens(self) -> None:
        """Note what the replay core counted before the window, which opens now."""
        self._start_ns = self.executor.clock.now_ns
        self._before = (*self.replayer.agreed, self.replayer.samples_perceived)

    @property
    def cycles(self) -> int:
        """Cycles judged: from the window's start up to the divergence that stopped
        replay, or all of them."""
        end = self._stopped_at[0] if self._stopped_at else self.executor.context.cycle + 1
        return max(0, end - self._start)

    @property
    def robot_time_ns(self) -> int:
        """Robot time judged, matching :attr:`cycles`."""
        end = self._stopped_at[1] if self._stopped_at else self.executor.clock.now_ns
        return max(0, end - self._start_ns)

    @property
    def checked(self) -> Checked:
        """What the cycles judged that agreed checked."""
        changes, outputs, draws = self.replayer.agreed
        changes_before, outputs_before, draws_before, samples_before = self._before
        return Checked(
            changes - changes_before + self._changes_checked,
            outputs - outputs_before + self._outputs_checked,
            draws - draws_before + self._draws_checked,
            self._samples_perceived - samples_before - self._samples_diverged,
        )

    @property
    def judging(self) -> bool:
        """Whether it still judges cycles: it has not stopped at a divergence."""
        return self._stopped_at is None

    def end(self) -> None:
        """Take the end of the session: what was followed past a divergence is written
        into it, and the samples perceived are counted."""
        if self._follower is not None:
            self._follower.end()
        if self._stopped_at is None:
            self._samples_perceived = self.replayer.samples_perceived

    def log_ended(self, why: str, cycles: int) -> None:
        """Record that the log stopped before the recording closed it, after ``cycles``
        cycles (before a fresh start, if it stopped there)."""
        context = self.executor.context
        if self.divergence is None:
            self.divergence = Divergence(
                kind=DivergenceKind.LOG_ENDED,
                cycle=min(context.cycle + 1, cycles),
                time_ns=context.time_ns,
                message=f"the log ends early ({why}); if the session ended there (a crash), "
                "accept what it holds with --allow-truncated (in a spec: allow_truncated = true)",
            )
        self.divergent_cycles += 1

    def judge(
        self,
        index: int,
        record: CycleRecord,
        changes: list[StateChangeRecord] | None,
        outcome: CycleOutcome | None,
    ) -> Follower | None:
        """Judge a cycle that did not agree at once, the ``index``-th of its batch (see
        :meth:`~beatlog.replaying.session.Judge.judge`): it agrees when it went cleanly
        (or only as an approved baseline lets it differ) and its state changes and
        outputs match: byte for byte, else by the :class:`Comparison` (state changes as
        a set, allowances applied). Only a cycle that does not agree gets its full
        outcome. A cycle before the window is not judged: it fails only where replay
        cannot go on past it."""
        replayer = self.replayer
        if self._start and self.executor.context.cycle < self._start:
            if changes is not None:
                return None
            outcome = outcome or replayer.outcome()
            if replayer.stop(outcome) is None:
                return None
            return self._stop(index, outcome, None)
        if changes is None:
            outcome = outcome or replayer.outcome()  # judged by its robot state, then as usual
            changes = outcome.changes if self._agrees_but_for_pins(outcome) else None
        unloggable: Exception | None = None
        if changes is not None:
            outputs = self.executor.context.outputs
            try:
                if replayer.agrees(record, changes) or (
                    self.comparison.changes_agree(
                        self._named(record.state_changes), self._named_actual(changes)
                    )
                    and self.comparison.outputs_agree(
                        self._expected_outputs(record.outputs), outputs
                    )
                ):
                    self._changes_checked += len(changes)
                    self._outputs_checked += len(outputs)
                    self._draws_checked += len(replayer.random.recorded)  # it drew them all
                    if self._invariants is None:
                        return None
                    outcome = outcome or replayer.outcome()
                    violation = self._invariants.check(outcome)
                    if violation is None:
                        return None
                    return self._stop(index, outcome, violation)
            except (TypeError, ValueError, msgspec.EncodeError) as exc:  # cannot be logged
                unloggable = exc
        outcome = outcome or replayer.outcome()
        if unloggable is not None:
            outcome = outcome._replace(failure=unloggable)
        # In a cycle that differs, an invariant that does not hold is the headline: it
        # says what is wrong, where the difference says only that something changed.
        violation = None if self._invariants is None else self._invariants.check(outcome)
        return self._stop(index, outcome, violation)

    def _stop(
        self, index: int, outcome: CycleOutcome, violation: Divergence | None
    ) -> Follower | None:
        """Write up a cycle that diverged (``violation``: an invariant that did not hold
        in it) and, unless told to keep going, stop judging there."""
        first = self.divergence is None
        if first:
            self._recent = self._window(index)
        self._diverge(outcome, violation)
        if self._keep_going:
            if first:
                self._add_context([])
            return None
        self._stopped_at = (outcome.cycle + 1, outcome.time_ns)
        self._samples_perceived = self.replayer.samples_perceived
        self._follower = Follower(self)
        return self._follower

    def _expected_outputs(self, raw_outputs: msgspec.Raw) -> dict[str, Any]:
        cycle = self.executor.context.cycle
        return decode_part(self.path, raw_outputs, decode_outputs, "outputs", cycle)

    def _named(self, raw_changes: msgspec.Raw) -> list[StateChange]:
        """Expected state changes in current names.

        :raises beatlog.errors.CorruptLogError: one names a behavior the catalogue lacks.
        """
        names = self.expected_names
        renamed = self.comparison.renamed
        cycle = self.executor.context.cycle
        recorded = decode_part(self.path, raw_changes, decode_state_changes, "state changes", cycle)
        for index, _, _ in recorded:
            if not 0 <= index < len(names):
                raise CorruptLogError(
                    self.path,
                    f"damaged state changes in cycle {cycle}: behavior "
                    f"#{index} is not in the catalogue of {len(names)}",
                )
        return [
            renamed(StateChange(names[index], before, after)) for index, before, after in recorded
        ]

    def _named_actual(self, changes: list[StateChangeRecord]) -> list[StateChange]:
        """State changes the behaviors made, by name."""
        names = self.executor.behavior_ids
        return [StateChange(names[index], before, after) for index, before, after in changes]

    def _agrees_but_for_pins(self, outcome: CycleOutcome) -> bool:
        """Whether a cycle the core did not call clean went cleanly but for what the
        approved baseline pins: perception rebuilt the robot state as expected (within
        tolerance, or as pinned), and the draws made otherwise than recorded are ones
        the baseline approves (which they then use up)."""
        if not outcome.completed or outcome.perception_failure is not None:
            return False
        if (
            self.replayer.perception is not None
            and outcome.perception_differs
            and self._state_differences(outcome)
        ):
            return False
        differences = outcome.draw_differences
        if self._ledger is None:
            return not differences
        return self._ledger.check(outcome.cycle, differences or ()) is None

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
        current = set(self.executor.behavior_ids)
        return not {rename(name) for name in self.expected_names} <= current

    def row(self, outcome: CycleOutcome) -> ContextRow:
        """A cycle replayed past the divergence, as its context shows it."""
        return ContextRow(
            outcome.cycle,
            outcome.time_ns,
            tuple(self._named(outcome.record.state_changes)),
            tuple(self._named_actual(outcome.changes or [])),
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

    def _diverge(self, outcome: CycleOutcome, violation: Divergence | None = None) -> None:
        self.divergent_cycles += 1
        self._samples_diverged += len(outcome.samples)
        if self.divergence is not None:
            return
        record = outcome.record
        expected = self._named(record.state_changes)
        if violation is not None:  # what was expected of the cycle, beside what it saw
            self.divergence = dataclasses.replace(
                violation,
                expected=tuple(expected),
                expected_outputs=self._expected_outputs(record.outputs),
                random_recorded=tuple(
                    draw_reports(outcome.recorded_draws, self.replayer.header.behaviors)
                ),
            )
            return
        actual = self._named_actual(outcome.changes or [])
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
            message = f"outputs differ from {self._against}"
        if kind is not DivergenceKind.STATE_CHANGES and self.comparison.only_order_differs(
            expected, actual
        ):
            message += (
                "; the state changes differ only in the order behaviors are listed,"
                " which is no difference"
            )
        if outcome.cycle < self._start:
            message = f"before the window (cycle {self._start} on): {message}"
        completed = failure is None and outcome.draw_problem is None
        self.divergence = Divergence(
            kind=kind,
            cycle=outcome.cycle,
            time_ns=outcome.time_ns,
            message=message,
            behavior=behavior,
            expected=tuple(expected),
            actual=tuple(actual),
            expected_outputs=self._expected_outputs(record.outputs),
            actual_outputs=dict(outcome.outputs) if completed else {},
            robot_state=state_fields(outcome.state),
            random_recorded=tuple(
                draw_reports(outcome.recorded_draws, self.replayer.header.behaviors)
            ),
            random_drawn=tuple(draw_reports(outcome.drawn, self.replayer.executor.behavior_ids)),
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


class Follower:
    """Follows replay past the first divergence, as an observer of the replay session:
    a few cycles to show what happened next, or the whole rest of the log when the
    divergence looks like a renamed behavior; :meth:`end` writes them into it."""

    def __init__(self, judge: CycleJudge) -> None:
        self._judge = judge
        self._suspect = judge.rename_suspected()
        self._rows: list[ContextRow] = []
        self._limit = None if self._suspect else judge.context
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
        self._rows.append(self._judge.row(outcome))
        if len(self._rows) == self._limit:
            self.end()

    def end(self) -> None:
        """Write what was followed into the divergence (once)."""
        if not self._done:
            self._done = True
            self._judge.followed(self._rows, suspect=self._suspect)


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
                elif _ENCODE(before) != _ENCODE(after):
                    return {}
    if any(forward.get(old) != new for old, new in states):
        return {}
    return {old: new for old, new in forward.items() if old != new}


class _WhileJudging:
    """An observer of the verdict's replay for as long as the verdict judges: the cycles
    up to the first divergence, the one that stops replay included."""

    def __init__(self, observer: Observer, judge: CycleJudge) -> None:
        self._observer = observer
        self._judge = judge

    @property
    def replaying(self) -> bool:
        return self._judge.judging and self._observer.replaying

    @property
    def reading(self) -> bool:
        return self._judge.judging and self._observer.reading

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        self._observer.add(record, outcome)


class _Calling:
    """An ``observe`` callback as an observer: given every outcome."""

    replaying = reading = True

    def __init__(self, observe: Callable[[CycleOutcome], object]) -> None:
        self._observe = observe

    def add(self, record: CycleRecord, outcome: CycleOutcome | None) -> None:
        if outcome is not None:
            self._observe(outcome)


def _invariant_arguments(invariants: Sequence[object]) -> list[str]:
    """The ``--invariants`` option that names the invariants given as references (one
    given as an object has no name a command line could carry)."""
    named = [invariant for invariant in invariants if isinstance(invariant, str)]
    return ["--invariants", ",".join(named)] if named else []


def _nothing_checked(cycles: int) -> str:
    """Why a replay that found no difference is no pass: it compared nothing."""
    what = (
        "0 cycles"
        if not cycles
        else f"{cycles} cycle{'' if cycles == 1 else 's'} but no state change, output, "
        "draw or sample"
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
