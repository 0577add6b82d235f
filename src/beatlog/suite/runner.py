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
from beatlog.baseline.file import BaselineFile, expected_path, log_digest, read_baseline
from beatlog.baseline.policy import SpecOptions, UpdateMode, refusal
from beatlog.errors import BeatlogError, NotABeatlogError, RemoteLogError
from beatlog.log.recording import Recording
from beatlog.project.usercode import importable_near, load_perception
from beatlog.replay.baseline import Baseline
from beatlog.replay.debugger import break_on_divergence, unreached_break
from beatlog.replay.judge import replay
from beatlog.replay.random import ReplayRandom
from beatlog.replay.setup import built_for_replay, recorded_system
from beatlog.replay.verdict import Divergence, DivergenceKind, ReplayResult, reproduce_command
from beatlog.suite.approved import approved_for
from beatlog.suite.spec import DtcSpec
from beatlog.suite.variants import importable_invariants, replay_variant_of

if TYPE_CHECKING:
    from beatlog.analysis.details import Details
    from beatlog.analysis.timeline import Timeline, TimelineCollector
    from beatlog.audit.replays import Auditors, AuditReport
    from beatlog.log.reader import SessionLogReader

__all__ = ["SpecOutcome", "Verdict", "repeat_note", "run_spec", "suite_auditors"]


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
    update: Baseline | None = None
    """The new baseline, when run in :attr:`UpdateMode.NEW` and the DTC failed."""
    update_refused: str | None = None
    """Why a failed DTC cannot be re-baselined (it needs a new recording)."""
    audit: AuditReport | None = None
    """The determinism audit, when one was asked for and the DTC could run."""
    timelines: tuple[Timeline, ...] = ()
    """Timelines of what it did, when the suite was run with ``timelines``."""
    error_traceback: str | None = None
    """The traceback of the user's code behind the error, when their code raised it."""
    retries: int = 0
    """How many times the DTC was run again because the cluster's worker running it
    died."""
    log_digest: str | None = None
    """The SHA-256 of the log replayed, with an :attr:`update`: the pending baseline is
    written where the log may not be (behind a URL)."""
    open_loop: tuple[int, int] | None = None
    """Where the approved baseline says the behaviors left the recording (cycle, robot
    time in ns)."""
    storage_wait_s: float | None = None
    """For a log behind a URL: the seconds its copy took (a download, or the cache)."""
    recorded: RecordedChanges | None = None
    """The state changes its log recorded, when run with ``coverage`` (and read whole)."""
    recording: Recording | None = None
    """Its log as the verdict's replay read it, with an :attr:`update`, where it is small
    enough to keep: the pending baseline is weighed against it, not the file again."""

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
    if it has one; its outcome, whose wall time is the replay's alone. ``options`` may
    ask for a failure's new baseline, an audit (in ``auditors``' interpreters),
    timelines and break points. The log is read once: the verdict's replay takes its
    digest and keeps its bytes, from which a failure's details and a repeat replay come
    (:func:`repeat_note`); a log too large to keep is read again for the details, and
    not repeated. A log behind a URL is copied here first."""
    with importable_near(spec.spec_file):
        try:
            asked = time.perf_counter()
            with spec.readable_log() as log:
                waited = time.perf_counter() - asked
                outcome = _run_spec(
                    dataclasses.replace(spec, log=log), options or SpecOptions(), auditors
                )
        except (NotABeatlogError, RemoteLogError) as exc:
            return SpecOutcome(spec, Verdict.ERROR, None, str(exc), 0.0)
    if spec.log_url is None:
        return outcome
    result, error = outcome.result, outcome.error
    if result is not None:
        result = dataclasses.replace(result, log=spec.log, url=spec.log_url)
    return dataclasses.replace(
        outcome,
        spec=spec,
        result=result,
        error=None if error is None else error.replace(str(log), spec.log_url),
        storage_wait_s=waited,
    )


def _run_spec(spec: DtcSpec, options: SpecOptions, auditors: Auditors | None) -> SpecOutcome:
    started = time.perf_counter()
    baseline = expected_path(spec.path)
    log = Recording(spec.log)
    try:
        own = spec.source is None and spec.variant is None  # fleet logs and variants: none
        approved = read_baseline(baseline) if own and baseline.exists() else None
        stream = None if approved is None else approved.stream
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
            baseline=stream,
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
                observers=[_charting(system, approved, charts)] if options.timelines else (),
                readers=[functools.partial(_kept, recorded)] if options.coverage else (),
            )
        except BeatlogError:  # a baseline of another log says so, not what it made fail
            if approved is not None and log.digest is not None:
                approved_for(approved, log.path, log.digest)
            raise
        if approved is not None:  # made from this log, as the replay read it
            approved_for(approved, log.path, log.digest)
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
        updating = options.update is UpdateMode.NEW
        refused = refusal(divergence) if updating and divergence is not None else None
        details = _details(spec, log, system, divergence, approved, trace=updating, options=options)
        if divergence is not None and details is not None:
            divergence = dataclasses.replace(divergence, fields_read=details.fields_read)
        if spec.system is None:  # the log named it: say which, on every run
            notes += (f"replayed against {system}, which its log records and the project lists",)
        result = dataclasses.replace(
            result, divergence=divergence, reproduce=_rerun(spec), notes=notes
        )
        changes = digest = None
        if details is not None and details.trace is not None and refused is None:
            if details.trace.stopped is not None:
                refused = f"replay cannot go on past {details.trace.stopped}: re-record the session"
            else:
                changes = details.trace.baseline
                digest = log.digest or log_digest(spec.log)
        report = _audited(spec, system, auditors) if options.audit else None
        drawn: tuple[Timeline, ...] = ()
        if charts:
            drawn = (
                details.timelines
                if details is not None and details.timelines
                else (charts[0].timeline(None),)
            )
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
        baseline=baseline if stream is not None else None,
        update=changes,
        update_refused=refused,
        audit=report,
        timelines=drawn,
        log_digest=digest,
        open_loop=None if stream is None else stream.open_loop,
        recorded=recorded[0] if recorded else None,
        recording=None if changes is None or log.data is None else log,
    )


def repeat_note(first: Divergence, again: Divergence | None, audit: str) -> tuple[str, ...]:
    """The note on a failure that a second replay, of a fresh system in this process,
    does not repeat (``again`` is its first divergence, compared by cycle, kind and what
    replay did there, as text so that a NaN equals itself): the behaviors depend on
    something besides their log, which the audit (the command ``audit``) names."""

    def seen(divergence: Divergence) -> tuple[object, ...]:
        done = (divergence.actual, divergence.actual_outputs, divergence.random_drawn)
        return divergence.cycle, divergence.kind, repr(done)

    if again is not None and seen(first) == seen(again):
        return ()
    if again is None:
        how = f"fails at cycle {first.cycle} in one run and passes in the next"
    elif again.cycle != first.cycle:
        how = f"fails at a different cycle each run ({first.cycle}, then {again.cycle})"
    else:
        how = f"fails otherwise each run at cycle {first.cycle}"
    return (
        f"{how} on unchanged code: the behaviors are not deterministic; run "
        f"`{audit}` to find the call",
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
    system: str, approved: BaselineFile | None, charts: list[TimelineCollector]
) -> Callable[[SessionLogReader], TimelineCollector]:
    """What builds a timeline collector of the verdict's replay (kept in ``charts``),
    against the ``approved`` baseline: its lanes start from the states of a system
    built as the replayed one is, set-up draws and all."""
    from beatlog.analysis.timeline import TimelineCollector  # noqa: PLC0415 - when charting

    override = None if approved is None else approved.whole.changes_override()

    def chart(reader: SessionLogReader) -> TimelineCollector:
        built = built_for_replay(system, reader.header, reader.path, ReplayRandom())
        charts.append(TimelineCollector(reader, built, expected=override))
        return charts[-1]

    return chart


def _kept(kept: list[RecordedChanges], reader: SessionLogReader) -> RecordedChanges:
    """A reader of what the log recorded, kept in ``kept``."""
    kept.append(RecordedChanges(reader))
    return kept[-1]


def _details(
    spec: DtcSpec,
    log: Recording,
    system: str,
    divergence: Divergence | None,
    approved: BaselineFile | None,
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
        system,
        divergence,
        trace=trace,
        timelines=options.timelines,
        expected=(  # read whole for the timelines alone
            None if approved is None or not options.timelines else approved.whole.changes_override()
        ),
        perception=None if spec.perception is None else load_perception(spec.perception),
        match_draws=trace or approved is not None,
        rename=spec.comparison.rename,
        migration=spec.migration,
        fresh_from=spec.start_cycle if spec.fresh_start else 0,
    )


def _audited(spec: DtcSpec, system: str, auditors: Auditors | None) -> AuditReport:
    """The determinism audit of the DTC, in ``auditors``' interpreters if given."""
    from beatlog.audit.replays import audit  # noqa: PLC0415 - only when auditing

    return audit(
        spec.log,
        system,
        allow_truncated=spec.allow_truncated,
        migration=spec.migration,
        auditors=auditors,
    )


def suite_auditors(options: SpecOptions) -> AbstractContextManager[Auditors | None]:
    """The audit interpreters a process keeps for the specs it runs with ``options``
    (none where they are not audited), stopped when the context ends."""
    if not options.audit:
        return contextlib.nullcontext()
    from beatlog.audit.replays import Auditors  # noqa: PLC0415 - only when auditing

    return Auditors()
