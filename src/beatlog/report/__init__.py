"""Reports for people: replay verdicts, log summaries, suite results and determinism audits.

The names are imported on first use (they need rich).
"""

from typing import TYPE_CHECKING

from beatlog.log._lazy import lazy_names

if TYPE_CHECKING:
    from beatlog.report.console import plain_text as plain_text
    from beatlog.report.console import render_replay as render_replay
    from beatlog.report.console import render_suite as render_suite
    from beatlog.report.console import render_summary as render_summary
    from beatlog.report.counts import plural as plural
    from beatlog.report.counts import verdict_counts as verdict_counts
    from beatlog.report.suite import SuiteReport as SuiteReport
    from beatlog.report.suite import render_audit as render_audit

__getattr__ = lazy_names(__name__)
