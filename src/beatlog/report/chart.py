"""Draws a timeline with matplotlib for ``beatlog plot``: behavior lanes (recorded vs
replayed) over robot-state signals, the first divergence marked, as PNG, SVG or PDF (by
the file's suffix). The HTML report draws the same chart without matplotlib
(:mod:`beatlog.report.svg`). Needs the ``plot`` extra; figures are drawn without pyplot,
so no display or interactive backend is ever touched.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from matplotlib import rc_context
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from beatlog.analysis.timeline import Timeline
from beatlog.errors import OptionError
from beatlog.report.svg import PALETTE

__all__ = [
    "CHART_FORMATS",
    "WIDTH_PX",
    "chart_format",
    "chart_size",
    "draw_timeline",
    "write_chart",
]

CHART_FORMATS = ("png", "svg", "pdf")
"""The file formats a chart is written in, named by the file's suffix."""

WIDTH_PX = 1200
DPI = 100
_ROW_PX = 22
_SIGNAL_PX = 100
_FRAME_PX = 170
"""Title, legend, time axis and margins."""
_LABEL_SHARE = 0.04
"""An interval at least this share of the session wide gets its state written in it."""
_MAX_LEGEND = 24
_DIVERGENCE_COLOR = "#d62728"
_NOT_REPLAYED_COLOR = "#bbbbbb"


def chart_size(timeline: Timeline) -> tuple[int, int]:
    """The chart's width and height in pixels: a row per lane, a strip per signal."""
    return WIDTH_PX, _rows(timeline) * _ROW_PX + len(timeline.signals) * _SIGNAL_PX + _FRAME_PX


def _rows(timeline: Timeline) -> int:
    return max(len(timeline.lanes) * (2 if timeline.replayed else 1), 1)


def draw_timeline(timeline: Timeline) -> Figure:
    """The chart as a matplotlib figure of :func:`chart_size`."""
    with rc_context({"text.parse_math": False}):  # a "$" in a name is text, not TeX
        width, height = chart_size(timeline)
        figure = Figure(figsize=(width / DPI, height / DPI), dpi=DPI, layout="constrained")
        lanes_px = _rows(timeline) * _ROW_PX + 30
        axes = figure.subplots(
            1 + len(timeline.signals),
            1,
            sharex=True,
            squeeze=False,
            height_ratios=[lanes_px] + [_SIGNAL_PX] * len(timeline.signals),
        )[:, 0]
        start_s = timeline.start_ns / 1e9
        end_s = max(timeline.end_ns / 1e9, start_s + 1e-3)
        # one colour per state, in order of first appearance, the same in every lane
        colors = {label: PALETTE[n % len(PALETTE)] for n, label in enumerate(timeline.states())}
        _draw_lanes(axes[0], timeline, colors, end_s - start_s)
        for ax, signal in zip(axes[1:], timeline.signals, strict=True):
            ax.plot(
                [t / 1e9 for t in signal.time_ns], signal.value, drawstyle="steps-post", linewidth=1
            )
            ax.set_ylabel(signal.field, rotation=0, ha="right", va="center")
            ax.grid(True, alpha=0.3)
            if signal.flag:  # drawn as 0 and 1, labelled False and True
                ax.set_yticks([0, 1], ["False", "True"])
                ax.set_ylim(-0.15, 1.15)
        mark = timeline.divergence
        if mark is not None and timeline.start_ns <= mark.time_ns <= timeline.end_ns:
            for ax in axes:
                ax.axvline(mark.time_ns / 1e9, color=_DIVERGENCE_COLOR, linewidth=1.5)
            axes[0].plot(
                mark.time_ns / 1e9,
                0.6,
                marker="v",
                markersize=9,
                color=_DIVERGENCE_COLOR,
                clip_on=False,
            )
            axes[0].set_title(mark.describe(), loc="right", color=_DIVERGENCE_COLOR, fontsize=10)
        axes[-1].set_xlim(start_s, end_s)
        axes[-1].set_xlabel("robot time (s)")
        figure.suptitle(timeline.title)
        handles = [Patch(facecolor=color, label=label) for label, color in colors.items()]
        if handles:
            figure.legend(
                handles=handles[:_MAX_LEGEND],
                loc="outside lower center",
                ncols=min(len(handles), 8),
                fontsize=8,
                title="behavior states",
                title_fontsize=8,
            )
        return figure


def _draw_lanes(ax: Axes, timeline: Timeline, colors: dict[str, Any], duration_s: float) -> None:
    rows = timeline.rows()
    for row, (_, intervals, replayed) in enumerate(rows):
        for flickering in (False, True):
            chosen = [i for i in intervals if (i.flicker > 0) is flickering]
            if not chosen:
                continue
            ax.broken_barh(
                [(i.start_ns / 1e9, (i.end_ns - i.start_ns) / 1e9) for i in chosen],
                (-row - 0.4, 0.8),
                facecolors=[colors[str(i.state)] for i in chosen],
                edgecolors="white" if flickering else "none",
                hatch="////" if flickering else None,
            )
        for interval in intervals:
            width_s = (interval.end_ns - interval.start_ns) / 1e9
            if width_s >= _LABEL_SHARE * duration_s and not interval.flicker:
                middle = interval.start_ns / 1e9 + width_s / 2
                state = str(interval.state)
                ax.text(middle, -row, state, ha="center", va="center", fontsize=7, clip_on=True)
        if replayed and timeline.replayed_until_ns < timeline.end_ns:
            start = timeline.replayed_until_ns / 1e9
            ax.broken_barh(
                [(start, timeline.end_ns / 1e9 - start)],
                (-row - 0.4, 0.8),
                facecolors="none",
                edgecolors=_NOT_REPLAYED_COLOR,
                hatch="xx",
            )
    ax.set_yticks([-row for row in range(len(rows))], [label for label, _, _ in rows], fontsize=8)
    ax.set_ylim(-max(len(rows), 1) + 0.4, 0.6)
    ax.set_title("behavior states", loc="left", fontsize=10)


def chart_format(path: str | Path) -> str:
    """The format of a chart file, from its suffix: one of :data:`CHART_FORMATS`.

    :raises beatlog.errors.OptionError: the suffix names none of them.
    """
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in CHART_FORMATS:
        given = f"suffix .{suffix}" if suffix else "no suffix"
        known = ", ".join(f".{name}" for name in CHART_FORMATS)
        raise OptionError(f"{path}: a chart is written as {known}, not {given}")
    return suffix


def write_chart(timeline: Timeline, path: str | Path) -> None:
    """Draw the timeline into a file of :func:`chart_size` in the format its suffix names.

    :raises beatlog.errors.OptionError: the suffix names no format of :data:`CHART_FORMATS`.
    :raises OSError: the file cannot be written.
    """
    draw_timeline(timeline).savefig(path, format=chart_format(path), dpi=DPI)
