"""Runs DTC suites: each spec replayed in a worker process, all cores by default."""

from __future__ import annotations

import dataclasses
import functools
import multiprocessing
import signal
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from types import FrameType

from beatlog.analysis.details import Details, replay_details
from beatlog.analysis.timeline import Timeline
from beatlog.analysis.trace import Expectation, ReplayedTrace
from beatlog.audit.replays import AuditReport
from beatlog.audit.replays import audit as audit_replay
from beatlog.errors import BaselineError, BeatlogError
from beatlog.replay.judge import replay
from beatlog.replay.verdict import Divergence, DivergenceKind, ReplayResult, reproduce_command
from beatlog.suite.baseline import expected_path, log_digest, read_baseline
from beatlog.suite.policy import UpdateMode
from beatlog.suite.spec import DtcSpec
from beatlog.usercode import load_system

__all__ = ["SpecOutcome", "Verdict", "run_spec", "run_suite"]


class Verdict(StrEnum):
    """How one DTC ended."""

    PASSED = "passed"
    """Replay gave the expected behavior state changes and outputs."""
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
    """The new expected state changes and outputs, when run in :attr:`UpdateMode.NEW` and
    the DTC failed."""
    update_refused: str | None = None
    """Why a failed DTC cannot be re-baselined (it needs a new recording)."""
    audit: AuditReport | None = None
    """The determinism audit, when one was asked for and the DTC could run."""
    timelines: tuple[Timeline, ...] = ()
    """Behavior activity for charts, when the suite was run with ``timelines``."""
    error_traceback: str | None = None
    """The traceback of the user's code behind the error, when their code raised it."""

    @property
    def reproduce(self) -> str:
        """The command that reruns this DTC alone, with its allowances and baseline."""
        return _rerun(self.spec)

    @property
    def audit_findings(self) -> int:
        """What the determinism audit found; 0 without an audit."""
        return self.audit.problems if self.audit is not None else 0


_UPDATABLE = (DivergenceKind.STATE_CHANGES, DivergenceKind.OUTPUTS)


def run_spec(
    spec: DtcSpec,
    *,
    update: UpdateMode | str = UpdateMode.NONE,
    audit: bool = False,
    timelines: bool = False,
) -> SpecOutcome:
    """Replay one spec's log against its system, judged against its approved baseline
    if it has one. In :attr:`UpdateMode.NEW` a failure also traces the new state
    changes and outputs (nothing is written here: see :mod:`beatlog.suite.maintenance`),
    with ``audit`` its determinism is audited, with ``timelines`` what it did
    is charted; the outcome's wall time is the replay's alone. The result's reproduce
    command is ``beatlog test SPEC``, which judges exactly as this run did."""
    update = UpdateMode.parse(update)
    started = time.perf_counter()
    baseline = expected_path(spec.path)
    try:
        expected = None
        if baseline.exists():
            approved = read_baseline(baseline)
            if approved.log_digest != log_digest(spec.log):
                raise BaselineError(
                    baseline, f"approved for another recording than {spec.log.name}; delete it"
                )
            expected = approved.expectation
        result = replay(
            spec.log,
            spec.system,
            allow_truncated=spec.allow_truncated,
            comparison=spec.comparison,
            expected=expected,
            explain=False,
            perception=spec.perception,
        )
        wall = time.perf_counter() - started
        divergence = result.divergence
        updating = update is UpdateMode.NEW and divergence is not None
        refused = _refusal(divergence) if updating and divergence is not None else None
        details = Details()
        if divergence is not None or timelines:
            details = replay_details(
                spec.log,
                load_system(spec.system),
                divergence,
                trace=updating and refused is None,
                timelines=timelines,
                expected=None if expected is None else expected.changes_by_cycle(),
            )
        if divergence is not None:
            divergence = dataclasses.replace(divergence, fields_read=details.fields_read)
        result = dataclasses.replace(result, divergence=divergence, reproduce=_rerun(spec))
        changes = None
        if details.trace is not None:
            changes, refused = _new_expectation(details.trace)
        report = (
            audit_replay(spec.log, spec.system, allow_truncated=spec.allow_truncated)
            if audit
            else None
        )
        drawn = details.timelines
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
    )


def _rerun(spec: DtcSpec) -> str:
    """``beatlog test SPEC``: the one command that judges a DTC as a suite run does,
    with the spec's allowances and approved baseline."""
    return reproduce_command("test", spec.path)


def _refusal(divergence: Divergence) -> str | None:
    """Why a divergence cannot be re-baselined, if it cannot."""
    if divergence.kind not in _UPDATABLE:
        return f"a divergence in {divergence.kind} cannot be re-baselined: re-record the session"
    return None


def _new_expectation(trace: ReplayedTrace) -> tuple[Expectation | None, str | None]:
    """The whole new trace of state changes and outputs, or why the recording cannot
    give one."""
    if trace.stopped is not None:
        return None, f"replay cannot go on past {trace.stopped}: re-record the session"
    return trace.expectation, None


def run_suite(
    specs: Sequence[DtcSpec],
    *,
    jobs: int = 1,
    fail_fast: bool = False,
    update: UpdateMode | str = UpdateMode.NONE,
    audit: bool = False,
    timelines: bool = False,
    on_outcome: Callable[[SpecOutcome], object] | None = None,
) -> list[SpecOutcome]:
    """Run every spec, ``jobs`` at a time in worker processes; outcomes in spec order.

    With ``fail_fast`` the first failure or error cancels the specs not yet started.
    In :attr:`UpdateMode.NEW` each failure carries its new expectation (nothing is
    written here: see :mod:`beatlog.suite.maintenance`); with ``audit`` each worker also
    audits its spec's determinism; with ``timelines`` it
    builds its DTC's timelines for charts.
    """
    update = UpdateMode.parse(update)
    outcomes: dict[Path, SpecOutcome] = {}

    def done(outcome: SpecOutcome) -> bool:
        outcomes[outcome.spec.path] = outcome
        if on_outcome is not None:
            on_outcome(outcome)
        return fail_fast and outcome.verdict is not Verdict.PASSED

    if jobs <= 1 or len(specs) <= 1:
        for spec in specs:
            if done(run_spec(spec, update=update, audit=audit, timelines=timelines)):
                break
    else:
        run = functools.partial(run_spec, update=update, audit=audit, timelines=timelines)
        _run_in_workers(run, specs, min(jobs, len(specs)), done)
    return [outcomes[spec.path] for spec in specs if spec.path in outcomes]


def _run_in_workers(
    run: Callable[[DtcSpec], SpecOutcome],
    specs: Sequence[DtcSpec],
    workers: int,
    done: Callable[[SpecOutcome], bool],
) -> None:
    """Run the specs in a pool until ``done`` says stop. On any exception, Ctrl-C
    included, the specs not started are cancelled and the workers are killed at once."""
    before = set(multiprocessing.active_children())
    context = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(workers, mp_context=context, initializer=_leave_interrupts)
    try:
        pending = {pool.submit(run, spec) for spec in specs}
        while pending:
            finished, pending = wait(pending, return_when=FIRST_COMPLETED)
            # Record every finished outcome before deciding to stop: any() over a
            # generator would drop the ones after the first failure.
            stops = [done(future.result()) for future in finished]
            if any(stops):
                break
    except BaseException:
        for worker in set(multiprocessing.active_children()) - before:
            worker.kill()
        raise
    finally:
        pool.shutdown(cancel_futures=True)


def _leave_interrupts() -> None:
    """Workers leave Ctrl-C to the parent, which stops them: no traceback from each.

    A handler that does nothing, not ``SIG_IGN``, so that the processes a worker
    starts (audit replays) are not born deaf to Ctrl-C.
    """
    signal.signal(signal.SIGINT, _do_nothing)


def _do_nothing(signum: int, frame: FrameType | None) -> None:
    """A signal handler that lets the signal pass."""
