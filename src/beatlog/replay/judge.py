"""The replay engine (the paper's Algorithm 2): run a system on a session log and judge it.

For each cycle t it advances a simulated clock by HB_t (never waiting), loads RS_t,
updates the behaviors with RN_t as their random numbers and compares the behavior
state changes and outputs with the recorded ones: byte for byte first, and only when
the bytes differ by the spec's comparison, which takes a cycle's state changes as a set.
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import msgspec

from beatlog.errors import CorruptLogError, EmptyCheckError
from beatlog.log.format import (
    DECODE_ERRORS,
    EMPTY_LIST,
    EMPTY_MAP,
    CycleRecord,
    StateChangeRecord,
    payload_encoder,
)
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import System
from beatlog.model.perception import Perception, PerceptionTypeError
from beatlog.model.random import Draw, plain_value
from beatlog.project import vouched_system
from beatlog.replay.compare import Comparison, state_fields
from beatlog.replay.core import CycleOutcome, Replayer, actor_name
from beatlog.replay.draws import DrawLedger, Unapproved
from beatlog.replay.expectation import Expectation
from beatlog.replay.fit import check_catalogue, check_state_fields
from beatlog.replay.migration import StateMigration
from beatlog.replay.pins import PinChecker, rebuilt_otherwise
from beatlog.replay.renames import propose_renames
from beatlog.replay.session import ReplaySession, fields_read
from beatlog.replay.verdict import (
    Checked,
    ContextRow,
    Divergence,
    DivergenceKind,
    DrawReport,
    FieldDifference,
    ReplayResult,
    StateChange,
    reproduce_command,
)
from beatlog.usercode import load_perception, load_system, user_traceback

__all__ = ["NO_SAMPLES", "recorded_system", "replay"]

NO_SAMPLES = (
    "perception not run: the log holds no samples (record with --log-samples); "
    "its recorded robot states were replayed"
)
"""The note on a replay given a perception step for a log recorded without samples."""


def replay(
    log: str | Path,
    system: System | str | None = None,
    *,
    keep_going: bool = False,
    allow_truncated: bool = False,
    allow_empty: bool = False,
    context_cycles: int = 5,
    comparison: Comparison | None = None,
    expected: Expectation | None = None,
    explain: bool = True,
    perception: Perception | str | None = None,
    break_at: int | None = None,
    observe: Callable[[CycleOutcome], object] | None = None,
    migration: StateMigration | None = None,
) -> ReplayResult:
    """Replay ``log`` against ``system`` (a system, or a ``module:factory`` reference;
    by default the reference recorded in the log's header, see :func:`recorded_system`).

    Stops at the first divergence unless ``keep_going`` is set, in which case it
    replays every cycle and counts the ones that diverged. A truncated log fails
    with a LOG_ENDED divergence after its last complete cycle unless
    ``allow_truncated`` is set. The divergence carries the state changes of up to
    ``context_cycles`` cycles before and after it. The result counts what was checked
    (:class:`~beatlog.replay.verdict.Checked`); a replay that checked nothing (no
    cycle, or no state change, output, random draw or sample in any) is no pass: it
    raises :class:`~beatlog.errors.EmptyCheckError` unless ``allow_empty`` is set.

    ``comparison`` says what counts as the same (renames, ignored behaviors and output
    fields, tolerances; exact by default). ``expected`` is an approved baseline to judge
    against instead of the recording: its state changes, and its outputs when it pins
    them (else the recorded outputs); the recording's heartbeats, robot states and
    random numbers are still used (and in sensor-level replay, the robot states it pins
    instead of the recorded ones). When the behaviors differ from what was expected
    only by a consistent renaming, the divergence proposes the rename map. Given a
    ``module:factory`` reference and ``explain``, the divergence also names the
    robot-state fields the behaviors read in that cycle (one more replay, of a fresh
    system; a suite gathers them with its other details instead). The result's
    reproduce command replays with these options, except ``comparison`` and
    ``expected``, which a spec carries (see :func:`beatlog.suite.run_spec`).

    ``perception`` (a perception step, or a ``module:factory`` that builds one) turns on
    sensor-level replay when the log holds samples: RS_t is rebuilt from each cycle's
    samples and compared with the recorded one, field by field within the comparison's
    robot-state tolerances (a PERCEPTION divergence names the fields that differ and the
    samples), and the behaviors run on the rebuilt state, tolerated differences and all.
    ``break_at`` stops in the debugger (``breakpoint()``, honouring ``PYTHONBREAKPOINT``)
    just before the behaviors update in that cycle. ``observe`` is given every cycle's
    outcome up to the first divergence (the one that stops replay included), e.g. a
    :class:`~beatlog.analysis.timeline.TimelineCollector`'s, so a report is gathered in
    the verdict's own replay. ``migration`` maps robot-state fields renamed or retyped
    since the recording onto the system's (:mod:`beatlog.replay.migration`); the
    reproduce command carries it.

    :raises beatlog.errors.LogError: the log is missing, foreign, corrupt or its robot
        state does not fit the system's robot state type (see :mod:`beatlog.replay.fit`).
    :raises beatlog.errors.FieldError: a robot-state tolerance names a field the recorded
        robot state lacks.
    :raises beatlog.errors.EmptyCheckError: the replay found no difference, but checked
        nothing either, and ``allow_empty`` is not set.
    """
    if system is None:
        system = recorded_system(log)
    reference = system if isinstance(system, str) else None
    if isinstance(system, str):
        system = load_system(system)
    perception_reference = perception if isinstance(perception, str) else None
    if isinstance(perception, str):
        perception = load_perception(perception)
    comparison = comparison or Comparison()
    migration = migration or StateMigration()
    started = time.perf_counter()  # the replay's wall time counts opening and checking the log
    with ReplaySession(
        log,
        system,
        perception=perception,
        break_at=break_at,
        migration=migration,
        living=expected is not None,
        rename=comparison.rename,
        state_pins=None if expected is None else PinChecker(expected.state_pins),
    ) as session:
        reader = session.reader
        check_state_fields(
            reader.header,
            comparison.state_tolerance,
            reader.path,
            "robot-state tolerance for",
            migration,
        )
        assert session.replayer is not None  # a session with a system replays
        judge = _Judge(
            session.replayer,
            keep_going=keep_going,
            context=context_cycles,
            comparison=comparison,
            expected=expected,
            observe=observe,
        )
        if judge.replayer.perception is None and observe is None:
            # State-level replay without observers needs RS_t decoded, and only that:
            # decoded with each batch, it is read once (the log fits: checked above).
            reader.decode_states(judge.replayer.state_type)
        status = None
        batches = judge.expected_batches(reader.batches())
        for batch in batches:
            stop = judge.run(batch)
            if stop is not None:
                wall = time.perf_counter() - started
                judge.follow(batch[stop + 1 :], batches)
                for _ in batches:  # a damaged log is bad input, wherever the damage is
                    pass
                status = reader.status
                break
        else:
            status = reader.status
            if not status.complete and not allow_truncated:
                judge.log_ended(status.describe())
            wall = time.perf_counter() - started
    divergence = judge.divergence
    checked = judge.checked
    if divergence is None and not allow_empty and not checked.anything:
        raise EmptyCheckError(reader.path, _nothing_checked(judge.cycles))
    if (
        explain
        and divergence is not None
        and reference
        and divergence.kind is not DivergenceKind.LOG_ENDED
    ):
        read = fields_read(log, load_system(reference), divergence.cycle, migration=migration)
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
        reproduce=reproduce_command(
            "replay",
            log,
            "--system",
            reference or reader.header.system or "MODULE:FACTORY",
            *(["--perception", perception_reference] if perception_reference else []),
            *(["--keep-going"] if keep_going else []),
            *(["--allow-truncated"] if allow_truncated else []),
            *(["--allow-empty"] if allow_empty else []),
            *migration.arguments(),
        ),
        notes=(NO_SAMPLES,) if perception is not None and judge.replayer.perception is None else (),
    )


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
    :func:`beatlog.project.vouched_system`.

    :raises beatlog.errors.SystemLoadError: the log records none, or one the project
        does not list.
    """
    with SessionLogReader(log) as reader:
        reference = reader.header.system
    return vouched_system(log, reference, project=Path.cwd() if project is None else project)


class _Judge:
    """Replays cycles and keeps the first divergence; the hot loop lives in :meth:`run`."""

    def __init__(
        self,
        replayer: Replayer,
        *,
        keep_going: bool,
        context: int,
        comparison: Comparison,
        expected: Expectation | None,
        observe: Callable[[CycleOutcome], object] | None = None,
    ) -> None:
        header, path = replayer.header, replayer.path
        self.header = header
        self.comparison = comparison
        self._keep_going = keep_going
        self._context = context
        self._batches: deque[Sequence[CycleRecord]] = deque(maxlen=context + 1)
        """The last batches: they hold the cycles before a divergence (none is empty)."""
        self._recent: list[CycleRecord] = []
        """The cycles before the first divergence, then the divergence."""
        self.path = path
        self.replayer = replayer
        check_catalogue(header, replayer.system, path, comparison.renames)
        replayer.random.expect_actors(
            header.behaviors, replayer.executor.behavior_ids, comparison.rename
        )
        self.random = self.replayer.random
        self.executor = self.replayer.executor
        self._observe = observe
        self.divergence: Divergence | None = None
        self.divergent_cycles = 0
        self._stopped_at: tuple[int, int] | None = None
        self._changes_checked = self._outputs_checked = self._draws_checked = 0
        """The state changes, outputs and draws of the cycles that agreed."""
        self._samples_perceived = 0
        """The replay core's count of samples perceived, when the last batch ended."""
        self._samples_diverged = 0
        """The samples of the cycles that diverged."""
        self._encoder = payload_encoder()
        self._baseline: dict[int, msgspec.Raw] | None = None
        self._baseline_outputs: dict[int, msgspec.Raw] | None = None
        self.expected_names = list(header.behaviors)
        self._ledger = None if expected is None else DrawLedger(expected.draws)
        """In living replay (an approved baseline), the draws it lets differ."""
        self._draw_cycles = frozenset() if self._ledger is None else self._ledger.cycles
        self._pinned_states: dict[int, dict[str, Any]] = {}
        """The robot states a format 3 baseline pins: fields by cycle (sensor-level replay)."""
        self._state_pins: PinChecker | None = None
        """The robot states a baseline pins by digest (sensor-level replay)."""
        self._pinned_cycles: frozenset[int] = frozenset()
        if expected is not None and self.replayer.perception is not None:
            self._pinned_states = expected.states_by_cycle()
            self._state_pins = self.replayer.state_pins
            self._pinned_cycles = frozenset(self._pinned_states)
            """The cycles a format 3 baseline pins (the replay core judges the cycles
            pinned by digest)."""
        if expected is not None and not expected.as_recorded:
            self._baseline = self._encode_baseline(expected)
            if expected.outputs is not None:
                self._baseline_outputs = self._encode_outputs(expected)
        # Pinned outputs are encoded with sorted keys, whatever order the behaviors
        # report them in; recorded ones in the order they were reported.
        self._outputs_encoder = (
            self._encoder
            if self._baseline_outputs is None
            else msgspec.msgpack.Encoder(enc_hook=self._encoder.enc_hook, order="sorted")
        )
        self._same_catalogue = self.executor.behavior_ids == self.expected_names
        self._changes_decoder = msgspec.msgpack.Decoder(list[StateChangeRecord])
        self._outputs_decoder = msgspec.msgpack.Decoder(dict[str, Any])

    def _encode_baseline(self, expected: Expectation) -> dict[int, msgspec.Raw]:
        """Encode an approved baseline like recorded state changes, by the system's catalogue.

        Behaviors the baseline names but the system lacks get indices past its catalogue.
        """
        names = list(self.executor.behavior_ids)
        index = {name: position for position, name in enumerate(names)}
        encoded: dict[int, msgspec.Raw] = {}
        for cycle, changes in expected.changes_by_cycle().items():
            records: list[StateChangeRecord] = []
            for behavior, before, after in changes:
                if behavior not in index:
                    index[behavior] = len(names)
                    names.append(behavior)
                records.append((index[behavior], before, after))
            if records:
                encoded[cycle] = msgspec.Raw(self._encoder.encode(records))
        self.expected_names = names
        return encoded

    def _encode_outputs(self, expected: Expectation) -> dict[int, msgspec.Raw]:
        """The pinned outputs of every cycle where they change, encoded with sorted keys."""
        encode = msgspec.msgpack.Encoder(order="sorted").encode
        return {
            cycle: msgspec.Raw(encode(outputs)) for cycle, outputs in expected.outputs_by_cycle()
        }

    def expected_batches(
        self, batches: Iterator[Sequence[CycleRecord]]
    ) -> Iterator[Sequence[CycleRecord]]:
        """The log's batches, with an approved baseline's state changes in place of BS_t
        and its outputs in place of the recorded ones, when it pins them."""
        baseline = self._baseline
        if baseline is None:
            yield from batches
            return
        pinned = self._baseline_outputs
        outputs = EMPTY_MAP
        cycle = 0
        for batch in batches:
            for record in batch:
                record.state_changes = baseline.get(cycle, EMPTY_LIST)
                if pinned is not None:
                    outputs = pinned.get(cycle, outputs)
                    record.outputs = outputs
                cycle += 1
            yield batch

    @property
    def against(self) -> str:
        """What replay is judged against, for messages."""
        return "the recording" if self._baseline is None else "the approved baseline"

    @property
    def outputs_against(self) -> str:
        """What the outputs are judged against, for messages."""
        if self._baseline is None:
            return "the recording"
        if self._baseline_outputs is None:
            return "the recording (the approved baseline pins no outputs: re-approve it)"
        return "the approved baseline"

    @property
    def cycles(self) -> int:
        """Cycles judged: up to the divergence that stopped replay, or all of them."""
        return self._stopped_at[0] if self._stopped_at else self.executor.context.cycle + 1

    @property
    def robot_time_ns(self) -> int:
        """Robot time judged, matching :attr:`cycles`."""
        return self._stopped_at[1] if self._stopped_at else self.executor.clock.now_ns

    @property
    def checked(self) -> Checked:
        """What the cycles judged that agreed checked."""
        return Checked(
            self._changes_checked,
            self._outputs_checked,
            self._draws_checked,
            self._samples_perceived - self._samples_diverged,
        )

    def _tally(self, changes: int, outputs: int, draws: int) -> None:
        """Add what a batch's cycles that agreed checked (counted as they are judged)."""
        self._changes_checked += changes
        self._outputs_checked += outputs
        self._draws_checked += draws
        self._samples_perceived = self.replayer.samples_perceived

    def run(self, batch: Sequence[CycleRecord]) -> int | None:
        """Replay a batch of cycles; the index of the cycle where replay stops, if it does.

        Each cycle is stepped by the replay core; a cycle agrees when it went cleanly
        (:meth:`Replayer.advance`) and its state changes and outputs match: byte for
        byte first, else by :class:`Comparison` (state changes as a set, allowances
        applied). Only a cycle that does not agree gets its full outcome. What the cycles
        that agree checked is counted as they are judged: a few additions a cycle.
        """
        self._batches.append(batch)
        encode = self._encoder.encode
        encode_outputs = self._outputs_encoder.encode
        advance = self.replayer.advance
        outcome_of = self.replayer.outcome
        context = self.executor.context
        observe = self._observe
        same_catalogue = self._same_catalogue
        raw = msgspec.Raw
        pinned_states = self._pinned_cycles
        draw_cycles = self._draw_cycles
        random = self.random
        changed = reported = drawn = 0
        for index, record in enumerate(batch):
            changes = advance(record)
            outcome: CycleOutcome | None = None
            if observe is not None:
                outcome = outcome_of()
                observe(outcome)
            if changes is None or (
                (pinned_states and context.cycle in pinned_states) or context.cycle in draw_cycles
            ):
                outcome = outcome or outcome_of()  # judged by its robot state, then as usual
                changes = outcome.changes if self._agrees_but_for_pins(outcome) else None
            unloggable: Exception | None = None
            if changes is not None:
                outputs = context.outputs
                try:
                    if (
                        (
                            record.state_changes == EMPTY_LIST
                            if not changes
                            else same_catalogue and record.state_changes == raw(encode(changes))
                        )
                        or self._changes_agree(record.state_changes, changes)
                    ) and (
                        (
                            record.outputs == EMPTY_MAP
                            if not outputs
                            else record.outputs == raw(encode_outputs(outputs))
                        )
                        or self._outputs_agree(record.outputs, outputs)
                    ):
                        changed += len(changes)
                        reported += len(outputs)
                        drawn += len(random.recorded)  # an agreeing cycle drew them all
                        continue
                except (TypeError, ValueError, msgspec.EncodeError) as exc:  # cannot be logged
                    unloggable = exc
            outcome = outcome or outcome_of()
            if unloggable is not None:
                outcome = outcome._replace(failure=unloggable)
            first = self.divergence is None
            if first:
                self._recent = self._window(index)
            self._diverge(outcome)
            if first and self._keep_going:
                self._add_context([])
            if not self._keep_going:
                self._stopped_at = (outcome.cycle + 1, outcome.time_ns)
                self._tally(changed, reported, drawn)
                return index
        self._tally(changed, reported, drawn)
        return None

    def _window(self, index: int) -> list[CycleRecord]:
        """The cycle at ``index`` in the last batch, with up to ``context`` cycles before it."""
        *earlier, last = self._batches
        records = [record for batch in earlier for record in batch]
        records.extend(last[: index + 1])
        return records[-(self._context + 1) :]

    def follow(self, rest: Sequence[CycleRecord], batches: Iterator[Sequence[CycleRecord]]) -> None:
        """Replay past the divergence: a few cycles to show what happened next, or the
        whole rest of the log when the divergence looks like a renamed behavior."""
        suspect = self._rename_suspected()
        rows: list[ContextRow] = []
        records = itertools.chain(rest, itertools.chain.from_iterable(batches))
        limit = None if suspect else self._context
        for outcome in self.replayer.outcomes(itertools.islice(records, limit)):
            if outcome.changes is None or outcome.failure is not None:
                suspect = False  # the first divergence is reported; replay cannot go on
                break
            rows.append(self._row(outcome))
        self._add_context(rows[: self._context])
        if suspect and self.divergence is not None:
            kept = self.comparison.kept
            cycles = [(self.divergence.expected, self.divergence.actual)]
            cycles.extend((row.expected, row.actual) for row in rows)
            renames = propose_renames((kept(want), kept(got)) for want, got in cycles)
            self.divergence = dataclasses.replace(self.divergence, proposed_renames=renames)

    def _rename_suspected(self) -> bool:
        """Whether the divergence is in state changes and expected behaviors are missing."""
        if self.divergence is None or self.divergence.kind is not DivergenceKind.STATE_CHANGES:
            return False
        rename = self.comparison.rename
        return not {rename(name) for name in self.expected_names} <= set(self.executor.behavior_ids)

    def _row(self, outcome: CycleOutcome) -> ContextRow:
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

    def _decode(self, data: msgspec.Raw, decode: Any, what: str) -> Any:
        try:
            return decode(data)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(
                self.path, f"damaged {what} in cycle {self.executor.context.cycle}: {exc}"
            ) from None

    def log_ended(self, why: str) -> None:
        """Record that the log stopped before the recording closed it."""
        context = self.executor.context
        if self.divergence is None:
            self.divergence = Divergence(
                kind=DivergenceKind.LOG_ENDED,
                cycle=context.cycle + 1,
                time_ns=context.time_ns,
                message=f"the log ends early ({why}); if the session ended there (a crash), "
                "accept what it holds with --allow-truncated (in a spec: allow_truncated = true)",
            )
        self.divergent_cycles += 1

    def _changes_agree(self, raw_changes: msgspec.Raw, changes: list[StateChangeRecord]) -> bool:
        return self.comparison.changes_agree(self._named(raw_changes), self._named_actual(changes))

    def _outputs_agree(self, raw_outputs: msgspec.Raw, outputs: dict[str, Any]) -> bool:
        expected = self._decode(raw_outputs, self._outputs_decoder.decode, "outputs")
        return self.comparison.outputs_agree(expected, outputs)

    def _named(self, raw_changes: msgspec.Raw) -> list[StateChange]:
        """Expected state changes in current names.

        :raises beatlog.errors.CorruptLogError: one names a behavior the catalogue lacks.
        """
        names = self.expected_names
        renamed = self.comparison.renamed
        recorded = self._decode(raw_changes, self._changes_decoder.decode, "state changes")
        for index, _, _ in recorded:
            if not 0 <= index < len(names):
                raise CorruptLogError(
                    self.path,
                    f"damaged state changes in cycle {self.executor.context.cycle}: behavior "
                    f"#{index} is not in the catalogue of {len(names)}",
                )
        return [
            renamed(StateChange(names[index], before, after)) for index, before, after in recorded
        ]

    def _named_actual(self, changes: list[StateChangeRecord]) -> list[StateChange]:
        names = self.executor.behavior_ids
        return [StateChange(names[index], before, after) for index, before, after in changes]

    def _diverge(self, outcome: CycleOutcome) -> None:
        self.divergent_cycles += 1
        self._samples_diverged += len(outcome.samples)
        if self.divergence is not None:
            return
        record = outcome.record
        expected = self._named(record.state_changes)
        actual = self._named_actual(outcome.changes or [])
        expected_outputs = self._decode(record.outputs, self._outputs_decoder.decode, "outputs")
        mismatch = outcome.draw_problem
        failure = outcome.failure
        behavior: str | None = None
        trace: str | None = None
        kind: DivergenceKind
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
            kind, message, behavior = self._unapproved(unapproved)
        elif not self.comparison.changes_agree(expected, actual):
            # The first behavior difference is the headline, even when the changed
            # behavior then drew fewer random numbers than were recorded.
            kind = DivergenceKind.STATE_CHANGES
            message = f"behavior state changes differ from {self.against}"
            behavior = self.comparison.first_differing_behavior(expected, actual)
            if stop is not None:
                message += f", and then the behaviors {stop.message}"
        elif stop is not None:
            kind, message, behavior = stop
        elif unapproved is not None:
            kind, message, behavior = self._unapproved(unapproved)
        else:
            kind = DivergenceKind.OUTPUTS
            message = f"outputs differ from {self.outputs_against}"
        if kind is not DivergenceKind.STATE_CHANGES and self.comparison.only_order_differs(
            expected, actual
        ):
            message += (
                "; the state changes differ only in the order behaviors are listed,"
                " which is no difference"
            )
        completed = failure is None and mismatch is None
        self.divergence = Divergence(
            kind=kind,
            cycle=outcome.cycle,
            time_ns=outcome.time_ns,
            message=message,
            behavior=behavior,
            expected=tuple(expected),
            actual=tuple(actual),
            expected_outputs=expected_outputs,
            actual_outputs=dict(outcome.outputs) if completed else {},
            robot_state=state_fields(outcome.state),
            random_recorded=tuple(self._reports(outcome.recorded_draws, self.header.behaviors)),
            random_drawn=tuple(self._reports(outcome.drawn, self.executor.behavior_ids)),
            traceback=trace,
            perception=differences,
            samples=tuple((sample.sensor, sample.value) for sample in outcome.samples),
        )

    def _agrees_but_for_pins(self, outcome: CycleOutcome) -> bool:
        """Whether a cycle the core did not call clean went cleanly but for what the
        approved baseline pins: perception rebuilt the robot state as expected (within
        tolerance, or as pinned), and the draws made otherwise than recorded are ones
        the baseline approves (which they then use up)."""
        if not outcome.completed or outcome.perception_failure is not None:
            return False
        if self.replayer.perception is not None and self._state_differences(outcome):
            return False
        differences = outcome.draw_differences
        if self._ledger is None:
            return not differences
        return self._ledger.check(outcome.cycle, differences or ()) is None

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
            if pins.mismatch(outcome.cycle, self._state_bytes(outcome.state)) is None:
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

    def _unapproved(self, unapproved: Unapproved) -> tuple[DivergenceKind, str, str]:
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

    def _perception_message(
        self, outcome: CycleOutcome, differences: tuple[FieldDifference, ...]
    ) -> str:
        """Why the robot state rebuilt in a cycle is not the one expected."""
        pins = self._state_pins
        if pins is None or outcome.cycle not in pins:
            names = ", ".join(d.field for d in differences)
            pinned = self._pinned_cycles or (self._state_pins and self._state_pins.cycles)
            against = " from the approved baseline" if pinned else ""
            return f"the robot state rebuilt from the samples differs{against} in {names}"
        run = pins.run_at(outcome.cycle)
        rebuilt = state_fields(outcome.state)
        now = list(rebuilt_otherwise(state_fields(outcome.recorded_state), rebuilt))
        return (
            "the robot state rebuilt from the samples differs from the approved baseline "
            f"{pins.mismatch(outcome.cycle, self._state_bytes(outcome.state))}; "
            "it differs from the recording in "
            f"{', '.join(now) or 'no field'}, the approved one in {', '.join(run.fields)} "
            f"(cycles {run.cycle}–{run.last})"
        )

    def _reports(self, draws: Sequence[Draw], names: Sequence[str]) -> list[DrawReport]:
        return [
            DrawReport(
                actor_name(names, d.actor), d.kind, plain_value(d), d.call() if d.params else ""
            )
            for d in draws
        ]
