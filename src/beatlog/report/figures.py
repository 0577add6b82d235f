"""The charts of one DTC for the HTML report, drawn where the DTC was judged.

A suite worker turns a DTC's timelines (a close-up of the first divergence, if any,
then the whole session) into :class:`Chart` values, inline SVG and the states it
shows, and only those travel back to the runner: the page is assembled there from
markup, without drawing.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

from beatlog.analysis.timeline import Timeline
from beatlog.report.svg import svg_chart, timeline_states

__all__ = ["Chart", "dtc_charts"]


class Chart(NamedTuple):
    """One drawn chart of a DTC."""

    svg: str
    """The ``<svg>`` element."""
    states: tuple[str, ...]
    """The state labels it shows, in order of first appearance (the page colours them)."""
    caption: str


def dtc_charts(name: str, timelines: Sequence[Timeline]) -> tuple[Chart, ...]:
    """The charts of the DTC ``name``: every timeline but the last is a close-up."""
    close_ups = len(timelines) - 1
    return tuple(
        _chart(name, timeline, close_up=index < close_ups)
        for index, timeline in enumerate(timelines)
    )


def _chart(name: str, timeline: Timeline, *, close_up: bool) -> Chart:
    start_s, end_s = timeline.start_ns / 1e9, timeline.end_ns / 1e9
    if close_up:
        title = f"{name}: close-up of the first divergence, {start_s:.3f}–{end_s:.3f} s"
    else:
        title = f"{name}: the whole session, {timeline.cycles:,} cycles, {end_s:.1f} s"
    caption = "Behavior states as recorded and as replayed, with robot-state fields" + (
        "; the red line marks the first divergence." if timeline.divergence else "."
    )
    return Chart(svg_chart(timeline, title=title), tuple(timeline_states(timeline)), caption)
