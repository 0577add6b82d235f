"""Reports for people: replay verdicts, log summaries and suite results as rich renderables."""

from beatlog.report.console import plain_text, render_replay, render_suite, render_summary

__all__ = ["plain_text", "render_replay", "render_suite", "render_summary"]
