"""The verdict (the paper's Algorithm 2): replay a system on a session log and judge it.

Each cycle's state changes and outputs are compared with the recorded ones (or an
approved baseline's): byte for byte first, in the replay core, and only where the bytes
differ by the spec's comparison. The first cycle that still differs is the divergence.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import msgspec

from beatlog.errors import EmptyCheckError
from beatlog.log.format import CycleRecord, LoggedStateChange
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.log.recording import LogSource
from beatlog.model.behavior import System
from beatlog.model.invariant import Invariant
from beatlog.model.perception import Perception
from beatlog.model.setup import SystemFactory
from beatlog.project.usercode import load_perception
from beatlog.replay.approved_states import ApprovedStateChecker
from beatlog.replay.baseline import Baseline, BaselineStream
from beatlog.replay.compare import Comparison
from beatlog.replay.core import CycleOutcome, Replayer
from beatlog.replay.divergence import DivergenceWriter, Follower
from beatlog.replay.fit.check import (
    check_catalogue,
    check_state_fields,
    period_note,
    python_note,
)
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.invariants import InvariantChecker
from beatlog.replay.session import BatchReader, Calling, Observer, ReplaySession, fields_read
from beatlog.replay.setup import SetupDrawError, recorded_system
from beatlog.replay.verdict import (
    Checked,
    Divergence,
    DivergenceKind,
    ReplayResult,
    reproduce_command,
)
from beatlog.replay.window import Window

__all__ = ["NO_SAMPLES", "CycleJudge", "replay"]

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
    baseline: Baseline | BaselineStream | None = None,
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
    :func:`~beatlog.replay.setup.recorded_system`) and judge it. A factory is handed
    the recorded set-up draws (:mod:`beatlog.replay.setup`).

    Replay stops at the first divergence unless ``keep_going``, which replays every
    cycle and counts those that diverge. A truncated log fails with a LOG_ENDED
    divergence unless ``allow_truncated``. The divergence shows up to
    ``context_cycles`` cycles either side of it. A replay that checked nothing
    (:class:`~beatlog.replay.verdict.Checked`) is no pass unless ``allow_empty``.

    ``comparison`` says what counts as the same (renames, ignored behaviors and output
    fields, tolerances; exact by default). ``baseline`` is an approved baseline to judge
    against instead of the recording (read alongside the log when it is an
    :class:`~beatlog.replay.baseline.BaselineStream`): its state changes, outputs,
    approved draws and pinned robot states. Given a ``module:factory`` reference and
    ``explain``, the divergence names the robot-state fields the behaviors read in its
    cycle (one more replay, of a fresh system). The result's reproduce command replays
    with these options but ``comparison`` and ``baseline``, which a spec carries.

    ``perception`` (a perception step, or a ``module:factory`` that builds one) turns on
    sensor-level replay when the log holds samples: RS_t is rebuilt from each cycle's
    samples and compared with the recorded one within the comparison's robot-state
    tolerances (a PERCEPTION divergence otherwise), and the behaviors run on it.
    ``break_at`` stops in the debugger just before the behaviors update in that cycle.
    ``observe`` is given every cycle's outcome up to the one that stops replay, and so
    are the :class:`~beatlog.replay.session.Observer` that ``observers`` build from
    the opened log; ``readers`` build readers of its batches as recorded
    (:class:`~beatlog.replay.session.BatchReader`), which take the whole log.
    ``migration`` maps robot-state fields renamed or retyped since the recording
    (:mod:`beatlog.replay.fit.migration`). A log recorded at another heartbeat
    period than the system declares replays with a note saying so.

    ``invariants`` (:mod:`beatlog.model.invariant`: callables, classes instantiated afresh,
    or ``module:attribute`` references to either) are checked in every cycle whose
    update completes: the first that does not hold (or raises) is an INVARIANT
    divergence of its cycle, its headline where the cycle also differs.

    ``start_cycle`` and ``end_cycle`` (both inclusive) narrow the verdict to a window
    (:mod:`beatlog.replay.window`), from a fresh start with ``fresh_start``; the
    result then counts the window's cycles alone, and has no status where the log was
    not read to its end. A window past the log's last cycle is an error of ``where``
    (the spec that set it; by default the log).

    :raises beatlog.errors.LogError: the log is missing, foreign, corrupt or does not fit
        the system's robot state type (see :mod:`beatlog.replay.fit`).
    :raises beatlog.errors.FieldError: a robot-state tolerance names a field the recorded
        robot state lacks.
    :raises beatlog.errors.EmptyCheckError: nothing differed, but nothing was checked.
    :raises beatlog.errors.WindowError: the window starts or ends past the log's last
        cycle.
    """
    if system is None:
        system = recorded_system(Path(log))
    reference = system if isinstance(system, str) else None
    perception_reference = perception if isinstance(perception, str) else None
    if isinstance(perception, str):
        perception = load_perception(perception)
    comparison = comparison or Comparison()
    migration = migration or StateMigration()
    if isinstance(baseline, Baseline):
        baseline = baseline.stream()
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
            system,
            perception=perception,
            break_at=break_at,
            migration=migration,
            match_draws=baseline is not None,
            rename=comparison.rename,
            approved_states=None
            if baseline is None
            else ApprovedStateChecker(pinned=baseline.pinned),
            fresh_from=window.fresh_from,
        )
    except SetupDrawError as diverged:  # no cycle replayed
        setup = Divergence(DivergenceKind.SETUP, 0, 0, diverged.problem)
        wall, reproduced = time.perf_counter() - started, reproduce(diverged.recorded_system)
        return ReplayResult(Path(log), False, 0, Checked(), 0, wall, None, setup, 1, reproduced)
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
            baseline=baseline,
            window=window,
            invariants=checker,
            keep_going=keep_going,
            context=context_cycles,
        )
        watching = [factory(reader) for factory in observers]
        if observe is not None:
            watching.append(Calling(observe))
        if replayer.perception is None and not watching:
            # State-level replay without observers needs RS_t decoded, and only that:
            # decoded with each batch, it is read once (the log fits: checked above). A
            # rover replay takes 8.4 % fewer instructions (38,150 a cycle against 41,633).
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
        read = fields_read(
            log, reference, divergence.cycle, migration=migration, fresh_from=window.fresh_from
        )
        divergence = dataclasses.replace(divergence, fields_read=read)
    no_samples = NO_SAMPLES if perception is not None and replayer.perception is None else ""
    notes = (
        period_note(reader.header, replayer.system),
        no_samples,
        window.note(),
        python_note(
            reader.header,
            diverged=divergence is not None and divergence.kind is not DivergenceKind.LOG_ENDED,
        ),
    )
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
    """The verdict as a replay session's :class:`~beatlog.replay.session.Judge`: judges
    the cycles that do not agree at once (:meth:`judge`, the hot path) against the
    recording or the approved ``baseline``, and the ``invariants`` in every cycle (none
    then agrees at once), writes up the first divergence and counts those that diverge.
    """

    def __init__(
        self,
        replayer: Replayer,
        *,
        comparison: Comparison,
        baseline: BaselineStream | None,
        window: Window,
        invariants: InvariantChecker | None,
        keep_going: bool,
        context: int,
    ) -> None:
        header, self.executor = replayer.header, replayer.executor
        check_catalogue(header, replayer.system, replayer.path, comparison.renames)
        names = self.executor.behavior_ids
        replayer.random.expect_actors(header.behaviors, names, comparison.rename)
        self.replayer, self.window = replayer, window
        self._invariants, self._keep_going = invariants, keep_going
        self._writer = DivergenceWriter(
            replayer, comparison, baseline, start=window.start, context=context
        )
        self.divergence: Divergence | None = None
        self.divergent_cycles = 0
        self.judging = True  # until it stops at a divergence
        self._stopped: tuple[int, int, int] | None = None  # cycle, robot time, samples
        self._follower: Follower | None = None
        self._counted = [0, 0, 0, 0]
        """State changes, outputs and draws of the cycles that agreed here (those that
        agreed at once the replay core counts), and samples of those that diverged."""
        self.cycles = self.robot_time_ns = 0  # judged, known at the end, as is checked
        self.checked = Checked()
        self._writer.check_bytes(judged=invariants is not None)

    def batches(self, batches: Iterator[Sequence[CycleRecord]]) -> Iterator[Sequence[CycleRecord]]:
        """The log's batches, with an approved baseline's state changes and outputs in
        place of the recorded ones and cut by the window; each kept for the context of
        a divergence as it is handed on."""
        if self._writer.records is not None:
            first = self.executor.context.cycle + 1  # 0, or a fresh start's cycle
            batches = self._writer.records.batches(batches, self.replayer.path, first)
        for batch in self.window.batches(batches, self.replayer):
            self._writer.keep(batch)
            yield batch

    def judge(
        self,
        index: int,
        record: CycleRecord,
        changes: list[LoggedStateChange] | None,
        outcome: CycleOutcome | None,
    ) -> Follower | None:
        """Judge a cycle that did not agree at once, the ``index``-th of its batch: it
        agrees when it went cleanly (or only as an approved baseline lets it differ), its
        state changes and outputs match by the :class:`Comparison` and every invariant
        holds. A cycle before the window fails only where replay cannot go on past it."""
        replayer, writer = self.replayer, self._writer
        if self.executor.context.cycle < self.window.start:
            if changes is not None:
                return None
            outcome = outcome or replayer.outcome()
            return None if replayer.stop(outcome) is None else self._stop(index, outcome, None)
        if changes is None:
            outcome = outcome or replayer.outcome()  # judged by its robot state, then as usual
            changes = outcome.changes if writer.allows(outcome) else None
        agrees, unloggable = False, None
        if changes is not None:
            outputs = self.executor.context.outputs
            try:
                agrees = replayer.agrees(record, changes) or writer.agrees(record, changes)
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
            self.divergence = self._writer.first(index, outcome, violation)
        if self._keep_going:
            return None
        self.judging = False
        self._stopped = (outcome.cycle + 1, outcome.time_ns, self.replayer.samples_perceived)
        self._follower = self._writer.follower(self.divergence)
        return self._follower

    def end(self, status: LogStatus | None, where: Path, *, allow_truncated: bool) -> None:
        """Take the end of the session: count what was judged, write the cycles around
        the divergence into it, and judge how the log ended (``status``, see
        :meth:`~beatlog.replay.window.Window.log_ended`)."""
        context, window = self.executor.context, self.window
        now = (context.cycle + 1, context.time_ns, self.replayer.samples_perceived)
        cycle, time_ns, samples = self._stopped or now
        (changes, outputs, draws), before, here = self.replayer.agreed, window.before, self._counted
        self.cycles = max(0, cycle - window.start)
        self.robot_time_ns = max(0, time_ns - window.start_ns)
        self.checked = Checked(
            changes - before[0] + here[0],
            outputs - before[1] + here[1],
            draws - before[2] + here[2],
            samples - before[3] - here[3],
        )
        if self.divergence is not None:
            self.divergence = self._writer.with_context(self.divergence, self._follower)
        ended = (
            window.log_ended(status, where, cycle, time_ns, allow_truncated=allow_truncated)
            if self.judging
            else None
        )
        if ended is not None:
            self.divergent_cycles += 1
            self.divergence = self.divergence or ended


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
