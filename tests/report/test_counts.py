"""The counted words every report shares: one pluraliser, one closing line of verdicts."""

from __future__ import annotations

import pytest

from beatlog.report.counts import plural, verdict_counts
from beatlog.suite.runner import Verdict

PASSED, FAILED, ERROR = Verdict.PASSED, Verdict.FAILED, Verdict.ERROR


@pytest.mark.parametrize(
    ("count", "words"), [(0, "0 errors"), (1, "1 error"), (2, "2 errors"), (1000, "1000 errors")]
)
def test_a_noun_is_plural_unless_there_is_one(count: int, words: str) -> None:
    assert plural(count, "error") == words


@pytest.mark.parametrize(
    ("verdicts", "not_run", "line"),
    [
        ([], 0, "0 passed, 0 failed"),
        ([PASSED, PASSED, FAILED], 0, "2 passed, 1 failed"),
        ([PASSED, ERROR], 0, "1 passed, 0 failed, 1 error"),
        ([FAILED, ERROR, ERROR], 3, "0 passed, 1 failed, 2 errors, 3 not run"),
    ],
)
def test_the_closing_line_counts_passes_and_failures_then_errors_and_what_did_not_run(
    verdicts: list[Verdict], not_run: int, line: str
) -> None:
    assert verdict_counts(verdicts, not_run=not_run) == line
