"""Reports for people: replay verdicts, log summaries, suite results and determinism audits.

The names are imported on first use (they need rich).
"""

from typing import TYPE_CHECKING

from beatlog._lazy import lazy_names

if TYPE_CHECKING:
    from beatlog.report.audit import render_audit
    from beatlog.report.console import (
        plain_text,
        render_replay,
        render_suite,
        render_summary,
    )
    from beatlog.report.counts import plural, verdict_counts
    from beatlog.report.suite import SuiteReport

__all__ = [
    "SuiteReport",
    "plain_text",
    "plural",
    "render_audit",
    "render_replay",
    "render_suite",
    "render_summary",
    "verdict_counts",
]

__getattr__ = lazy_names(
    __name__,
    {
        "SuiteReport": "beatlog.report.suite",
        "plain_text": "beatlog.report.console",
        "plural": "beatlog.report.counts",
        "render_audit": "beatlog.report.audit",
        "render_replay": "beatlog.report.console",
        "render_suite": "beatlog.report.console",
        "render_summary": "beatlog.report.console",
        "verdict_counts": "beatlog.report.counts",
    },
)
