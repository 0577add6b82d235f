"""Runs one DTC: its spec's log replayed against its system, judged against its
baseline, audited and charted where asked for; its verdict and outcome. Suites run
their specs with it (:mod:`beatlog.suite.parallel`), here and in worker processes."""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import glob
import time
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING

from beatlog.analysis.recorded import RecordedChanges
from beatlog.analysis.trace import ReplayedTrace
from beatlog.baseline.file import Baseline, expected_path, log_digest, read_baseline
from beatlog.baseline.policy import SpecOptions, UpdateMode, refusal
from beatlog.errors import BaselineError, BeatlogError, RemoteLogError
from beatlog.log.recording import Recording
from beatlog.project.usercode import importable_near, load_perception, load_system
from beatlog.replaying.debugger import break_on_divergence, unreached_break
from beatlog.replaying.expectation import Expectation
from beatlog.replaying.judge import replay
from beatlog.replaying.random import ReplayRandom
from beatlog.replaying.setup import built_for_replay, recorded_system
from beatlog.replaying.verdict import Divergence, DivergenceKind, ReplayResult, reproduce_command
from beatlog.suite.remote import named_as_given
from beatlog.suite.repeats import repeat_note
from beatlog.suite.spec import DtcSpec
from beatlog.suite.variants import importable_invariants, replay_variant_of

if TYPE_CHECKING:
    from beatlog.analysis.details import Details
    from beatlog.analysis.timeline import Timeline, TimelineCollector
    from beatlog.audit.replays import Auditors, AuditReport
    from beatlog.log.reader import SessionLogReader

__all__ = ["SpecOutcome", "Verdict", "run_spec", "suite_auditors"]


class Verdict(StrEnum):
    """How one DTC ended."""

    PASSED = "passed"
    """Replay gave the expected behavior state changes and outputs (and, from samples,
    robot states)."""
    FAILED = "failed"
    """Replay diverged from the recording or the approved baseline."""
    ERROR = "error"
    """The DTC could not run: its log or system is bad input."""


@dataclass(frozen=True)
class SpecOutcome:
    """The verdict on one spec, with the replay result or the error that stopped it."""

    spec: DtcSpec
    verdict: Verdict
    result: ReplayResult | None
    error: str | None
    wall_time_s: float
    baseline: Path | None = None
    """The approved baseline judged against, when there is one."""
    update: Expectation | None = None
    """The new expected state changes, outputs and (from samples) robot states, when run
    in :attr:`UpdateMode.NEW` and the DTC failed."""
    update_refused: str | None = None
    """Why a failed DTC cannot be re-baselined (it needs a new recording)."""
    audit: AuditReport | None = None
    """The determinism audit, when one was asked for and the DTC could run."""
    timelines: tuple[Timeline, ...] = ()
    """Timelines of what it did (a close-up of the first divergence, if any, then the
    whole session), gathered where it was judged, when the suite was run with
    ``timelines``; reports draw them."""
    error_traceback: str | None = None
    """The traceback of the user's code behind the error, when their code raised it."""
    retries: int = 0
    """How many times the DTC was run again because the process running it died (a
    cluster's worker, see :mod:`beatlog.suite.cluster`)."""
    log_digest: str | None = None
    """The SHA-256 of the log replayed, with an :attr:`update`: the pending baseline is
    written where the log may not be (behind a URL)."""
    open_loop: tuple[int, int] | None = None
    """Where the approved baseline says the behaviors left the recording (cycle, robot
    time in ns): from there the recorded world no longer answers to them."""
    storage_wait_s: float | None = None
    """For a log behind a URL: the seconds spent waiting for its copy (a download, or
    the cache) before the replay could start; None for a log of this machine."""
    recorded: RecordedChanges | None = None
    """The state changes its log recorded, when run with ``coverage`` and its log could
    be read to the end."""
    recording: Recording | None = None
    """Its log as the verdict's replay read it, with an :attr:`update`, where it is small
    enough to keep: the pending baseline is weighed against it without reading the
    file again (:mod:`beatlog.suite.maintenance`)."""

    @property
    def verdict_label(self) -> str:
        """The verdict as reports show it: ``passed (approved baseline)``, ``passed
        (approved baseline, open loop since cycle 517)``, ``failed (retried 1×)``."""
        loop = f", open loop since cycle {self.open_loop[0]}" if self.open_loop else ""
        return (
            self.verdict.value
            + (f" (approved baseline{loop})" if self.baseline else "")
            + (f" (retried {self.retries}×)" if self.retries else "")
        )

    @property
    def reproduce(self) -> str:
        """The command that reruns this DTC alone, with its allowances and baseline."""
        return _rerun(self.spec)

    @property
    def audit_findings(self) -> int:
        """What the determinism audit found; 0 without an audit."""
        return self.audit.problems if self.audit is not None else 0


def run_spec(
    spec: DtcSpec, options: SpecOptions | None = None, *, auditors: Auditors | None = None
) -> SpecOutcome:
    """Replay one spec's log against its system, judged against its approved baseline
    if it has one. ``options`` may ask for more: in :attr:`UpdateMode.NEW` a failure
    also traces the new state changes and outputs (nothing is written here: see
    :mod:`beatlog.suite.maintenance`), with ``audit`` its determinism is audited, with
    ``timelines`` what it did is charted: a passing DTC from the verdict's own replay, a
    failing one from the one more replay its details take. A failed DTC is replayed
    once more, against a fresh system, to see that its first divergence repeats: where
    it does not, a note says so and points to the audit. The log is opened and read
    once: the verdict's replay takes its digest (which must be its approved baseline's)
    and keeps its bytes (:class:`~beatlog.log.recording.Recording`), which the details
    and the repeat replay from memory; a log too large to keep
    (:data:`~beatlog.log.recording.KEPT_BYTES`) is not replayed a third time to see
    that its failure repeats, and its details read it again. The outcome's wall time is
    the replay's alone. The result's reproduce command is ``beatlog test SPEC``, which
    judges exactly as this run did. The spec's references also import from its folder
    and its project root (:func:`beatlog.project.usercode.importable_near`). The options' break
    points stop in the debugger as ``beatlog replay --break-at`` and
    ``--break-on-divergence`` do (:mod:`beatlog.replaying.debugger`); a break past the end
    of the log is noted in the result. A variant is replayed perturbed, judged alone.
    A log behind a URL is copied here first (the time waited for it is the outcome's
    ``storage_wait_s``), and the copy removed after; one that cannot be copied is an
    error of the DTC. The audit runs in ``auditors``' interpreters
    (see :func:`suite_auditors`), else in interpreters of its own."""
    with importable_near(spec.spec_file):
        try:
            with contextlib.ExitStack() as copied:
                asked = time.perf_counter()
                log = copied.enter_context(spec.readable_log())
                waited = time.perf_counter() - asked
                outcome = _run_spec(
                    dataclasses.replace(spec, log=log), options or SpecOptions(), auditors
                )
        except RemoteLogError as exc:
            return SpecOutcome(spec, Verdict.ERROR, None, str(exc), 0.0)
        if spec.log_url is None:
            return outcome
        outcome = dataclasses.replace(outcome, storage_wait_s=waited)
        return _named_as_given(outcome, spec, str(log), spec.log_url)


def _named_as_given(outcome: SpecOutcome, spec: DtcSpec, copy: str, url: str) -> SpecOutcome:
    """The outcome of replaying a copy of a log behind a URL, with the spec as given and
    the URL where its error named the copy."""
    result = outcome.result
    if result is not None:
        result = dataclasses.replace(result, log=spec.log, url=url)
    error = None if outcome.error is None else named_as_given(outcome.error, copy, url)
    return dataclasses.replace(outcome, spec=spec, result=result, error=error)


def _run_spec(spec: DtcSpec, options: SpecOptions, auditors: Auditors | None) -> SpecOutcome:
    update, audit, timelines = options.update, options.audit, options.timelines
    started = time.perf_counter()
    baseline = expected_path(spec.path)
    log = Recording(spec.log)
    try:
        approved = None
        if spec.source is None and spec.variant is None and baseline.exists():
            approved = read_baseline(baseline)
        expected = None if approved is None else approved.stream
        system = spec.system or recorded_system(spec.log, project=spec.path.parent)
        if spec.variant is not None:  # no baseline; judged by not raising, and no more
            result = replay_variant_of(spec, system)
            verdict = Verdict.PASSED if result.ok else Verdict.FAILED
            return SpecOutcome(spec, verdict, result, None, result.wall_time_s)
        judged = functools.partial(
            replay,
            log,
            allow_truncated=spec.allow_truncated,
            allow_empty=spec.allow_empty,
            comparison=spec.comparison,
            expected=expected,
            explain=False,
            perception=spec.perception,
            migration=spec.migration,
            start_cycle=spec.start_cycle,
            end_cycle=spec.end_cycle,
            fresh_start=spec.fresh_start,
            where=spec.path,
            invariants=importable_invariants(spec),
        )
        charts: list[TimelineCollector] = []
        recorded: list[RecordedChanges] = []
        try:
            result = judged(
                system,
                break_at=options.break_at,
                observers=[_charting(system, approved, charts)] if timelines else (),
                readers=[functools.partial(_kept, recorded)] if options.coverage else (),
            )
        except BeatlogError:
            if log.digest is not None:  # the baseline's own error, if it is not this log's
                _approved_for(approved, baseline, log)
            raise
        _approved_for(approved, baseline, log)
        wall = time.perf_counter() - started
        divergence = result.divergence
        notes = result.notes + unreached_break(options.break_at, result)
        if options.break_on_divergence:
            notes += break_on_divergence(result, lambda cycle: judged(system, break_at=cycle))
        if (
            divergence is not None
            and divergence.kind is not DivergenceKind.LOG_ENDED
            and log.data is not None
            and not options.verdict_only
        ):
            notes += repeat_note(divergence, judged(system).divergence, _rerun(spec, "--audit"))
        updating = update is UpdateMode.NEW and divergence is not None
        refused = refusal(divergence) if updating and divergence is not None else None
        details = _details(spec, log, system, divergence, approved, trace=updating, options=options)
        if divergence is not None and details is not None:
            divergence = dataclasses.replace(divergence, fields_read=details.fields_read)
        if spec.system is None:  # the log named it: say which, on every run
            notes = (
                *notes,
                f"replayed against {system}, which its log records and the project lists",
            )
        result = dataclasses.replace(
            result, divergence=divergence, reproduce=_rerun(spec), notes=notes
        )
        changes = digest = None
        if details is not None and details.trace is not None and refused is None:
            changes, refused = _new_expectation(details.trace)
            digest = None if changes is None else log.digest or log_digest(spec.log)
        report = None
        if audit:
            from beatlog.audit.replays import audit as audit_replay  # noqa: PLC0415 - only when auditing

            report = audit_replay(
                spec.log,
                system,
                allow_truncated=spec.allow_truncated,
                migration=spec.migration,
                auditors=auditors,
            )
        drawn = _timelines(charts, details)
    except BeatlogError as exc:
        wall = time.perf_counter() - started
        return SpecOutcome(
            spec, Verdict.ERROR, None, str(exc), wall, error_traceback=exc.user_traceback
        )
    return SpecOutcome(
        spec,
        Verdict.PASSED if result.ok else Verdict.FAILED,
        result,
        None,
        wall,
        baseline=baseline if expected is not None else None,
        update=changes,
        update_refused=refused,
        audit=report,
        timelines=drawn,
        log_digest=digest,
        open_loop=None if expected is None else expected.open_loop,
        recorded=recorded[0] if recorded else None,
        recording=None if changes is None or log.data is None else log,
    )


def _approved_for(approved: Baseline | None, baseline: Path, log: Recording) -> None:
    """Refuse an ``approved`` baseline made from another recording than ``log``: its
    digest, taken as the replay read the log (or, where the replay stopped short of the
    log's end, from the file), must be the baseline's.

    :raises beatlog.errors.BaselineError: it was approved for another recording.
    """
    if approved is None:
        return
    if approved.log_digest != (log.digest or log_digest(log.path)):
        raise BaselineError(
            baseline, f"approved for another recording than {log.path.name}; delete it"
        )


def _rerun(spec: DtcSpec, *options: str) -> str:
    """``beatlog test SPEC``: the one command that judges a DTC as a suite run does,
    with the spec's allowances and approved baseline; for a fleet log, ``beatlog test
    --logs LOG --system MODULE:FACTORY``; for a variant, its own spec's (as written when
    it fails); ``options`` go before them."""
    if spec.source is None:
        return reproduce_command("test", *options, spec.own_spec)
    perception = () if spec.perception is None else ("--perception", spec.perception)
    system = () if spec.system is None else ("--system", spec.system)
    log = glob.escape(spec.source)
    return reproduce_command("test", *options, "--logs", log, *system, *perception)


def _charting(
    system: str, approved: Baseline | None, charts: list[TimelineCollector]
) -> Callable[[SessionLogReader], TimelineCollector]:
    """What builds a timeline collector of the verdict's replay from the log it opens
    (kept in ``charts``), against the ``approved`` baseline (read whole): its lanes
    start from the states of a system built as the replayed one is, set-up draws and
    all."""
    from beatlog.analysis.timeline import TimelineCollector  # noqa: PLC0415 - when charting

    override = None if approved is None else approved.expectation.changes_override()
    factory = functools.partial(load_system, system)

    def chart(reader: SessionLogReader) -> TimelineCollector:
        built = built_for_replay(factory, reader.header, reader.path, ReplayRandom())
        charts.append(TimelineCollector(reader, built, expected=override))
        return charts[-1]

    return chart


def _kept(kept: list[RecordedChanges], reader: SessionLogReader) -> RecordedChanges:
    """A reader of what the log recorded, kept in ``kept``."""
    kept.append(RecordedChanges(reader))
    return kept[-1]


def _timelines(charts: list[TimelineCollector], details: Details | None) -> tuple[Timeline, ...]:
    """The DTC's timelines: from the details of a failure, else from the verdict's replay."""
    if not charts:
        return ()
    if details is not None and details.timelines:
        return details.timelines
    return (charts[0].timeline(None),)


def _details(
    spec: DtcSpec,
    log: Recording,
    system: str,
    divergence: Divergence | None,
    approved: Baseline | None,
    *,
    trace: bool,
    options: SpecOptions,
) -> Details | None:
    """One more replay of a failed DTC for what reports need (none for the verdict alone),
    of the bytes the verdict's replay kept; timelines against ``approved`` (read whole)."""
    if divergence is None or options.verdict_only or divergence.kind is DivergenceKind.SETUP:
        return None
    from beatlog.analysis.details import replay_details  # noqa: PLC0415 - numpy, when needed

    return replay_details(
        log,
        functools.partial(load_system, system),
        divergence,
        trace=trace,
        timelines=options.timelines,
        expected=(  # read whole for the timelines alone
            None
            if approved is None or not options.timelines
            else approved.expectation.changes_override()
        ),
        perception=None if spec.perception is None else load_perception(spec.perception),
        living=trace or approved is not None,
        rename=spec.comparison.rename,
        migration=spec.migration,
        fresh_from=spec.start_cycle if spec.fresh_start else 0,
    )


def _new_expectation(trace: ReplayedTrace) -> tuple[Expectation | None, str | None]:
    """The whole new trace of state changes and outputs, or why the recording cannot
    give one."""
    if trace.stopped is not None:
        return None, f"replay cannot go on past {trace.stopped}: re-record the session"
    return trace.expectation, None


def suite_auditors(options: SpecOptions) -> AbstractContextManager[Auditors | None]:
    """The audit interpreters a process keeps for the specs it runs with ``options``
    (none where they are not audited), stopped when the context ends."""
    if not options.audit:
        return contextlib.nullcontext()
    from beatlog.audit.replays import Auditors  # noqa: PLC0415 - only when auditing

    return Auditors()
