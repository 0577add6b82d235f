"""The re-baselining workflow: update, review, approve, and the orphans left behind.

A run in :attr:`UpdateMode.NEW <beatlog.baseline.policy.UpdateMode.NEW>` writes each
failing DTC's new baseline to its pending file (:func:`update_baselines`); a
reviewer reads it as a diff (:func:`pending_diff`) and decides (:func:`decide`), or
accepts everything pending at once (:func:`approve`). An accepted baseline is never
overwritten by a failure, a pending file must come from the recording the spec names,
and nothing is written when ``CI`` is set. These functions write files and return
what they did; they never print: the CLI and the pytest plugin render the results.
"""

from __future__ import annotations

import contextlib
import difflib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import Any

from beatlog.analysis.recorded import read_changes
from beatlog.analysis.shift import Shift, shift
from beatlog.analysis.trace import WholeTrace, recorded_states, whole_trace
from beatlog.baseline.file import (
    EXPECTED_SUFFIX,
    PENDING_SUFFIX,
    expected_path,
    log_digest,
    pending_path,
    read_baseline,
    spec_path,
)
from beatlog.baseline.policy import UpdateMode, in_ci, require_writable
from beatlog.baseline.write import format_lines, write_baseline
from beatlog.errors import BaselineError, OptionError
from beatlog.log.recording import LogSource
from beatlog.replay.approved_state_lines import ApprovedRun
from beatlog.replay.baseline import Baseline
from beatlog.replay.draws import ApprovedDraws
from beatlog.suite.discovery import discover_specs, files_under
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.spec import DtcSpec
from beatlog.suite.variants import write_variant_spec

__all__ = [
    "Decision",
    "PendingDiff",
    "PendingUpdate",
    "UpdateAction",
    "approve",
    "decide",
    "find_orphans",
    "pending_diff",
    "pending_specs",
    "update_baselines",
    "write_failed_variants",
]


class UpdateAction(StrEnum):
    """What updating did with one DTC's pending baseline."""

    WRITTEN = "written"
    """The failure's new baseline went to its pending file."""
    WITHHELD = "withheld"
    """The failure has a new baseline, but ``CI`` is set: nothing was written."""
    REFUSED = "refused"
    """The divergence cannot be re-baselined (the session must be re-recorded)."""
    REMOVED = "removed"
    """The DTC passes again: its stale pending file was deleted."""


@dataclass(frozen=True)
class PendingUpdate:
    """One DTC's pending baseline after an update: what was done and to which file."""

    spec: DtcSpec
    action: UpdateAction
    path: Path
    """The pending file."""
    shift: Shift | None = None
    """What the baseline written (or withheld) loses and gains against today's."""
    baseline: Baseline | None = None
    """The baseline written (or withheld)."""
    reason: str | None = None
    """Why the update was refused."""


def write_failed_variants(outcomes: Iterable[SpecOutcome]) -> list[Path]:
    """Write every variant of ``outcomes`` that failed, and has no spec of its own yet,
    as a spec beside its DTC, in CI too; the paths written.

    :raises beatlog.errors.SpecError: one cannot be written; those before it stay.
    """
    return [
        write_variant_spec(outcome.spec)
        for outcome in outcomes
        if outcome.spec.variant is not None
        and outcome.verdict is Verdict.FAILED
        and outcome.spec.own_spec != outcome.spec.path
    ]


def update_baselines(
    outcomes: Iterable[SpecOutcome], mode: UpdateMode | str
) -> list[PendingUpdate]:
    """Apply an update mode to a suite's outcomes; what was done, in outcome order.

    In :attr:`UpdateMode.NEW` every failure that carries a new baseline gets it
    written to its pending file, and a passing DTC's stale pending file is removed;
    accepted baselines are never touched, and fleet logs and variants have none. When
    ``CI`` is set nothing is written: each such failure is :attr:`UpdateAction.WITHHELD`.

    :raises BaselineError: a pending file cannot be written (a full disk); those
        written before it stay, each whole.
    """
    if UpdateMode.parse(mode) is UpdateMode.NONE:
        return []
    done: list[PendingUpdate] = []
    ci = in_ci()
    for outcome in outcomes:
        spec, update = outcome.spec, outcome.update
        if spec.source is not None or spec.variant is not None:  # no baselines of their own
            continue
        pending = pending_path(spec.path)
        if update is not None:
            kept = outcome.recording  # the log as its run read it, if kept
            with contextlib.nullcontext(kept) if kept is not None else spec.readable_log() as log:
                weighed = _weigh(spec, log, update)[2]
            action = UpdateAction.WITHHELD if ci else UpdateAction.WRITTEN
            if not ci:
                write_baseline(
                    pending,
                    spec_name=spec.name,
                    log_name=spec.log_url or spec.log.name,
                    digest=outcome.log_digest or log_digest(spec.log),
                    baseline=update,
                )
            done.append(PendingUpdate(spec, action, pending, weighed, update))
        elif ci:
            continue
        elif outcome.update_refused is not None:
            done.append(
                PendingUpdate(spec, UpdateAction.REFUSED, pending, reason=outcome.update_refused)
            )
        elif outcome.verdict is Verdict.PASSED and pending.exists():
            pending.unlink()
            done.append(PendingUpdate(spec, UpdateAction.REMOVED, pending))
    return done


class Decision(StrEnum):
    """A reviewer's answer about one pending baseline."""

    ACCEPT = "accept"
    """The pending baseline becomes the approved baseline."""
    REJECT = "reject"
    """The pending file is deleted; the approved baseline, if any, stays."""
    SKIP = "skip"
    """Left pending, to decide later."""

    @classmethod
    def parse(cls, value: Decision | str) -> Decision:
        """The decision named by ``value`` or by its start (``a``, ``rej``), in any case;
        anything else raises :class:`OptionError` listing the decisions there are."""
        word = value.strip().lower()  # a Decision is its own word
        found = [decision for decision in cls if word and decision.value.startswith(word)]
        if len(found) != 1:
            valid = ", ".join(repr(decision.value) for decision in cls)
            raise OptionError(f"unknown decision {value!r}: choose one of {valid}")
        return found[0]


def pending_specs(paths: Sequence[Path]) -> list[DtcSpec]:
    """The specs given, or found in the folders given, that have a pending baseline."""
    return [spec for spec in discover_specs(paths) if pending_path(spec.path).exists()]


def decide(spec: DtcSpec, decision: Decision | str) -> None:
    """Accept or reject the pending baseline of ``spec``, or leave it (skip). A damaged
    pending file, or one made from another recording, is a :class:`BaselineError` and
    changes nothing; with ``CI`` set a decision is a :class:`~beatlog.errors.CiWriteError`.
    """
    decision = Decision.parse(decision)
    if decision is Decision.SKIP:
        return
    require_writable()
    pending = pending_path(spec.path)
    if decision is Decision.REJECT:
        pending.unlink()
        return
    baseline = read_baseline(pending)  # a damaged pending file must not become the baseline
    with spec.readable_log() as log:
        digest = log_digest(log)
    if baseline.log_digest != digest:
        raise BaselineError(pending, f"made from another recording than {spec.log.name}")
    pending.replace(expected_path(spec.path))


def approve(paths: Sequence[Path]) -> list[tuple[DtcSpec, Shift]]:
    """Accept the pending baseline of every spec given (or found in the folders given),
    as :func:`decide` does; the specs approved, each with what it lost and gained."""
    require_writable()
    approved = []
    for spec in pending_specs(paths):
        weighed = pending_diff(spec).shift
        decide(spec, Decision.ACCEPT)
        approved.append((spec, weighed))
    return approved


@dataclass(frozen=True)
class PendingDiff:
    """A pending baseline as a unified diff against today's: approved, else recorded."""

    spec: DtcSpec
    source: str
    """What the pending file is compared with, e.g. ``recorded (NAME.beatlog)``."""
    old_lines: int
    """State and output changes today."""
    new_lines: int
    """State and output changes pending."""
    lines: tuple[str, ...]
    """The diff: changed cycles with a line of context either side."""
    shift: Shift
    """What the pending baseline loses and gains against today's baseline."""
    rebuilt_runs: tuple[ApprovedRun, ...] = ()
    """The runs of cycles in which perception now rebuilds the robot state otherwise."""
    recorded: Mapping[int, Mapping[str, Any]] = field(default_factory=dict)
    """The robot state recorded in each run's first cycle, as fields."""
    draws: tuple[ApprovedDraws, ...] = ()
    """The draws the pending baseline lets replay make otherwise than recorded."""
    open_loop: tuple[int, int] | None = None
    """Where, pending, the behaviors leave the recording (cycle, robot time in ns)."""


def pending_diff(spec: DtcSpec) -> PendingDiff:
    """Compare the pending baseline of ``spec`` with its approved one, or with its
    recording when none is approved yet, interleaved by cycle as baseline files hold
    them; with the robot states perception now rebuilds otherwise, run by run, and what
    the pending baseline loses and gains."""
    expected = expected_path(spec.path)
    pending = read_baseline(pending_path(spec.path)).whole
    with spec.readable_log() as log:
        today, whole, weighed = _weigh(spec, log, pending)
        source = (
            f"approved ({expected.name})" if expected.exists() else f"recorded ({spec.log.name})"
        )
        runs = whole.baseline.approved_states.runs
        recorded = recorded_states(log, {run.cycle for run in runs})
    old = format_lines(today.changes, today.outputs, today.baseline.approved_states)
    new = format_lines(whole.changes, whole.outputs, whole.baseline.approved_states)
    diff = difflib.unified_diff(old, new, source, "pending", n=1, lineterm="")
    return PendingDiff(
        spec,
        source,
        len(old),
        len(new),
        tuple(diff),
        weighed,
        runs,
        recorded,
        whole.baseline.draws,
        whole.baseline.open_loop,
    )


def _weigh(
    spec: DtcSpec, log: LogSource, pending: Baseline
) -> tuple[WholeTrace, WholeTrace, Shift]:
    """Today's baseline of ``spec`` (approved, else recorded) and ``pending``, both
    as whole traces, and what ``pending`` loses and gains against today's."""
    expected = expected_path(spec.path)
    approved = read_baseline(expected).whole if expected.exists() else None
    today = whole_trace(approved, log, spec.comparison.rename)
    whole = whole_trace(pending, log, spec.comparison.rename)
    weighed = shift(
        (today.changes, today.outputs),
        (whole.changes, whole.outputs),
        cycles=read_changes(log).cycles,
        open_loop=None if whole.baseline.open_loop is None else whole.baseline.open_loop[0],
        draws_before=today.baseline.draws,
        draws_after=whole.baseline.draws,
    )
    return today, whole, weighed


def find_orphans(folders: Iterable[Path]) -> list[Path]:
    """Expected and pending files under ``folders`` whose spec no longer exists."""
    return sorted(
        {
            path
            for folder in folders
            if folder.is_dir()
            for suffix in (EXPECTED_SUFFIX, PENDING_SUFFIX)
            for path in files_under(folder, suffix)
            if not spec_path(path).is_file()
        }
    )
