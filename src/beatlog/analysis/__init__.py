"""What replays and logs tell beyond a verdict: whole-session traces, timelines for
charts and a log's figures."""

from beatlog.analysis.summary import LogSummary, summarize
from beatlog.analysis.trace import ReplayedTrace, recorded_trace, replayed_trace

__all__ = [
    "LogSummary",
    "ReplayedTrace",
    "recorded_trace",
    "replayed_trace",
    "summarize",
]
