"""Counted words for every report: one pluraliser and the suite's closing counts."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable

from beatlog.suite.runner import Verdict

__all__ = ["plural", "verdict_counts"]


def plural(count: int, noun: str) -> str:
    """The count and its noun, plural unless the count is one: ``1 DTC``, ``0 errors``."""
    return f"{count} {noun}{'' if count == 1 else 's'}"


def verdict_counts(verdicts: Iterable[Verdict], *, not_run: int = 0, open_loop: int = 0) -> str:
    """``2 passed, 1 failed``, then the errors, the DTCs not run and the DTCs judged
    open loop (their behaviors left the recording: worth recording again), when there
    are any."""
    counts = Counter(verdicts)
    line = f"{counts[Verdict.PASSED]} passed, {counts[Verdict.FAILED]} failed"
    if counts[Verdict.ERROR]:
        line += f", {plural(counts[Verdict.ERROR], 'error')}"
    if not_run:
        line += f", {not_run} not run"
    if open_loop:
        line += f", {open_loop} open loop (worth re-recording when convenient)"
    return line
