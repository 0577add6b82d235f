"""The replay engine (the paper's Algorithm 2): run a system on a session log and judge it.

For each cycle t it advances a simulated clock by HB_t (never waiting), loads RS_t,
updates the behaviors with RN_t as their random numbers and compares the behavior
state changes and outputs with the recorded ones: byte for byte first, and only when
the bytes differ by the spec's comparison, which takes a cycle's state changes as a set.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from beatlog.errors import EmptyCheckError
from beatlog.log.format import CycleRecord
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import System
from beatlog.model.perception import Perception
from beatlog.project import vouched_system
from beatlog.replay.compare import Comparison
from beatlog.replay.core import CycleOutcome
from beatlog.replay.cycle_judge import CycleJudge
from beatlog.replay.expectation import Expectation
from beatlog.replay.fit import check_state_fields
from beatlog.replay.migration import StateMigration
from beatlog.replay.pins import PinChecker
from beatlog.replay.session import BatchReader, Observer, ReplaySession, fields_read
from beatlog.replay.verdict import DivergenceKind, ReplayResult, reproduce_command
from beatlog.usercode import load_perception, load_system

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
    observers: Sequence[Callable[[SessionLogReader], Observer]] = (),
    readers: Sequence[Callable[[SessionLogReader], BatchReader]] = (),
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
    outcome up to the first divergence (the one that stops replay included), and
    ``observers`` build, from the opened log, observers
    (:class:`~beatlog.replay.session.Observer`, e.g. a
    :class:`~beatlog.analysis.timeline.TimelineCollector`) that take the same cycles, so
    that a report is gathered in the verdict's own replay; ``readers`` build readers of
    its batches as recorded (:class:`~beatlog.replay.session.BatchReader`, e.g. a
    :class:`~beatlog.analysis.recorded.RecordedChanges` for the coverage), which take
    the whole log. ``migration`` maps robot-state fields renamed or retyped since the
    recording onto the system's (:mod:`beatlog.replay.migration`); the reproduce command
    carries it.

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
        judge = CycleJudge(
            session.replayer,
            keep_going=keep_going,
            context=context_cycles,
            comparison=comparison,
            expected=expected,
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
        status = reader.status
        if judge.judging and not status.complete and not allow_truncated:
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
