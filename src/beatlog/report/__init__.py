"""Reports for people: replay verdicts, log summaries, suite results and determinism audits."""

from beatlog.report.audit import render_audit
from beatlog.report.console import plain_text, render_replay, render_suite, render_summary
from beatlog.report.counts import plural, verdict_counts

__all__ = [
    "plain_text",
    "plural",
    "render_audit",
    "render_replay",
    "render_suite",
    "render_summary",
    "verdict_counts",
]
