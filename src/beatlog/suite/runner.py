"""Runs DTC suites: each spec replayed in a worker process, all cores by default."""

from __future__ import annotations

import multiprocessing
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from enum import StrEnum

from beatlog.engine.replay import replay
from beatlog.engine.timeline import Timeline, report_timelines
from beatlog.engine.verdict import ReplayResult
from beatlog.errors import BeatlogError
from beatlog.suite.spec import DtcSpec

__all__ = ["SpecOutcome", "Verdict", "run_spec", "run_suite"]


class Verdict(StrEnum):
    """How one DTC ended."""

    PASSED = "passed"
    """Replay gave the recorded behavior state changes and outputs."""
    FAILED = "failed"
    """Replay diverged from the recording."""
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
    timelines: tuple[Timeline, ...] = ()
    """Behavior activity for charts, when the suite was run with ``timelines``."""


def run_spec(spec: DtcSpec, *, timelines: bool = False) -> SpecOutcome:
    """Replay one spec's log against its system; with ``timelines``, also chart what it did."""
    started = time.perf_counter()
    try:
        result = replay(spec.log, spec.system, allow_truncated=spec.allow_truncated)
        wall = time.perf_counter() - started
        drawn = report_timelines(spec.log, spec.system, result.divergence) if timelines else ()
    except BeatlogError as exc:
        return SpecOutcome(spec, Verdict.ERROR, None, str(exc), time.perf_counter() - started)
    verdict = Verdict.PASSED if result.ok else Verdict.FAILED
    return SpecOutcome(spec, verdict, result, None, wall, drawn)


def run_suite(
    specs: Sequence[DtcSpec],
    *,
    jobs: int = 1,
    fail_fast: bool = False,
    on_outcome: Callable[[SpecOutcome], object] | None = None,
    timelines: bool = False,
) -> list[SpecOutcome]:
    """Run every spec, ``jobs`` at a time in worker processes; outcomes in spec order.

    With ``fail_fast`` the first failure or error cancels the specs not yet started.
    With ``timelines`` each worker also builds its DTC's timeline for charts.
    """
    outcomes: dict[DtcSpec, SpecOutcome] = {}

    def done(outcome: SpecOutcome) -> bool:
        outcomes[outcome.spec] = outcome
        if on_outcome is not None:
            on_outcome(outcome)
        return fail_fast and outcome.verdict is not Verdict.PASSED

    if jobs <= 1 or len(specs) <= 1:
        for spec in specs:
            if done(run_spec(spec, timelines=timelines)):
                break
    else:
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=min(jobs, len(specs)), mp_context=context) as pool:
            pending: set[Future[SpecOutcome]] = {
                pool.submit(run_spec, spec, timelines=timelines) for spec in specs
            }
            while pending:
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                # Record every finished outcome before deciding to stop: any() over a
                # generator would drop the ones after the first failure.
                stops = [done(future.result()) for future in finished]
                if any(stops):
                    for future in pending:
                        future.cancel()
                    break
    return [outcomes[spec] for spec in specs if spec in outcomes]
