"""Draws a timeline as an ``<svg>`` element for the HTML report, with nothing but strings.

The chart :mod:`beatlog.report.chart` draws with matplotlib, in milliseconds instead of
most of a second. Every text is escaped, the markup has no ids (charts share a page) and
each bar carries its state's class (:func:`state_key`): an HTML report's stylesheet
gives each state one colour by its first appearance in the report (:func:`state_styles`),
so a state looks the same in every chart; a chart alone falls back to a colour chosen by
its key.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterable
from html import escape

from beatlog.analysis.timeline import Signal, Timeline

__all__ = ["PALETTE", "WIDTH_PX", "fallback_color", "state_key", "state_styles", "svg_chart"]

PALETTE = (
    "#1f77b4",
    "#aec7e8",
    "#ff7f0e",
    "#ffbb78",
    "#2ca02c",
    "#98df8a",
    "#d62728",
    "#ff9896",
    "#9467bd",
    "#c5b0d5",
    "#8c564b",
    "#c49c94",
    "#e377c2",
    "#f7b6d2",
    "#7f7f7f",
    "#c7c7c7",
    "#bcbd22",
    "#dbdb8d",
    "#17becf",
    "#9edae5",
)
"""matplotlib's ``tab20``: ten hues, each dark and light."""


def state_key(label: str) -> str:
    """A CSS class for a state label, the same in every process and run: ``s-`` and hex."""
    return "s-" + hashlib.blake2b(label.encode(), digest_size=4).hexdigest()


def fallback_color(label: str) -> str:
    """The colour a state has by its key alone, where no stylesheet says otherwise."""
    return PALETTE[int(state_key(label)[2:], 16) % len(PALETTE)]


def state_styles(labels: Iterable[str]) -> str:
    """CSS rules giving each state (in order of first appearance) the next palette colour."""
    ordered = dict.fromkeys(labels)
    return "".join(
        f".{state_key(label)}{{fill:{PALETTE[index % len(PALETTE)]}}}"
        for index, label in enumerate(ordered)
    )


WIDTH_PX = 1200
_LEFT = 200
"""Room for lane names and signal fields."""
_RIGHT = 20
_PLOT = WIDTH_PX - _LEFT - _RIGHT
_ROW = 22
_BAR = 16
_SIGNAL = 100
_SIGNAL_GAP = 18
_LEGEND_COLUMNS = 6
_LEGEND_ROW = 18
_MAX_LEGEND = 24
_LABEL_SHARE = 0.04
"""An interval at least this share of the chart wide gets its state written in it."""
_DIVERGENCE = "#d62728"
_NOT_REPLAYED = "#bbbbbb"
_FONT = 'font-family="sans-serif"'


def svg_chart(timeline: Timeline, *, title: str | None = None) -> str:
    """The timeline as an inline ``<svg>`` element, the same for the same timeline."""
    return _Drawing(timeline).draw(title or timeline.title)


class _Drawing:
    def __init__(self, timeline: Timeline) -> None:
        self.timeline = timeline
        self.start_s = timeline.start_ns / 1e9
        self.span_s = max(timeline.end_ns / 1e9 - self.start_s, 1e-3)
        self.parts: list[str] = []

    def x(self, time_ns: int) -> float:
        return _LEFT + (time_ns / 1e9 - self.start_s) / self.span_s * _PLOT

    def draw(self, title: str) -> str:
        timeline = self.timeline
        add = self.parts.append
        add(_label(WIDTH_PX / 2, 22, title, 15, "middle"))
        mark = timeline.divergence
        if mark is not None:
            add(_label(WIDTH_PX - _RIGHT, 44, mark.describe(), 12, "end", fill=_DIVERGENCE))
        add(_label(_LEFT, 44, "behavior states", 12))
        top = 54
        bottom = self._lanes(top)
        for signal in timeline.signals:
            bottom = self._signal(signal, bottom + _SIGNAL_GAP)
        if mark is not None and timeline.start_ns <= mark.time_ns <= timeline.end_ns:
            x = self.x(mark.time_ns)
            add(
                f'<line x1="{x:.1f}" y1="{top - 4}" x2="{x:.1f}" y2="{bottom}" '
                f'stroke="{_DIVERGENCE}" stroke-width="1.5"/>'
            )
            add(f'<path d="M{x - 5:.1f} {top - 10}h10l-5 8z" fill="{_DIVERGENCE}"/>')
        bottom = self._time_axis(bottom)
        height = self._legend(bottom + 10)
        return (
            f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH_PX}" height="{height}" '
            f'viewBox="0 0 {WIDTH_PX} {height}" class="timeline-chart">'
            + "".join(self.parts)
            + "</svg>"
        )

    def _lanes(self, top: int) -> int:
        timeline = self.timeline
        add = self.parts.append
        rows = timeline.rows()
        for row, (label, intervals, replayed) in enumerate(rows):
            y = top + row * _ROW
            add(_label(_LEFT - 6, y + _ROW / 2 + 4, label, 11, "end"))
            bar_y = y + (_ROW - _BAR) / 2
            for interval in intervals:
                x = self.x(interval.start_ns)
                width = self.x(interval.end_ns) - x
                state = str(interval.state)
                flicker = ' fill-opacity="0.45"' if interval.flicker else ""
                add(
                    f'<rect x="{x:.1f}" y="{bar_y}" width="{max(width, 0.3):.1f}" height="{_BAR}" '
                    f'class="{state_key(state)}" fill="{fallback_color(state)}"{flicker}/>'
                )
                if width >= _LABEL_SHARE * _PLOT and not interval.flicker:
                    add(_label(f"{x + width / 2:.1f}", bar_y + _BAR / 2 + 3, state, 9, "middle"))
            if replayed and timeline.replayed_until_ns < timeline.end_ns:
                x = self.x(timeline.replayed_until_ns)
                add(
                    f'<rect x="{x:.1f}" y="{y + (_ROW - _BAR) / 2}" '
                    f'width="{self.x(timeline.end_ns) - x:.1f}" height="{_BAR}" '
                    f'fill="{_NOT_REPLAYED}" fill-opacity="0.4"/>'
                )
        add(_frame(top, max(len(rows), 1) * _ROW))
        return top + max(len(rows), 1) * _ROW

    def _signal(self, signal: Signal, top: int) -> int:
        add = self.parts.append
        height = _SIGNAL - _SIGNAL_GAP
        bottom = top + height
        low, high, ticks = _value_axis(signal)

        def y(value: float) -> float:
            return bottom - (value - low) / (high - low) * height

        add(_frame(top, height))
        add(_label(_LEFT - 50, top + height / 2 + 4, signal.field, 11, "end"))
        for value, label in ticks:
            add(_label(_LEFT - 4, f"{y(value) + 3:.1f}", label, 9, "end"))
            add(
                f'<line x1="{_LEFT}" y1="{y(value):.1f}" x2="{_LEFT + _PLOT}" '
                f'y2="{y(value):.1f}" stroke="#ddd"/>'
            )
        if signal.time_ns:
            steps = [f"M{self.x(signal.time_ns[0]):.1f} {y(signal.value[0]):.1f}"]
            for time_ns, value in zip(signal.time_ns[1:], signal.value[1:], strict=True):
                steps.append(f"H{self.x(time_ns):.1f}V{y(value):.1f}")
            steps.append(f"H{self.x(self.timeline.end_ns):.1f}")
            add(f'<path d="{"".join(steps)}" fill="none" stroke="#1f77b4" stroke-width="1"/>')
        return bottom

    def _time_axis(self, top: int) -> int:
        add = self.parts.append
        end_s = self.start_s + self.span_s
        for tick in _ticks(self.start_s, end_s, 10):
            x = _LEFT + (tick - self.start_s) / self.span_s * _PLOT
            add(f'<line x1="{x:.1f}" y1="{top}" x2="{x:.1f}" y2="{top + 4}" stroke="#444"/>')
            add(_label(f"{x:.1f}", top + 16, f"{tick:g}", 10, "middle"))
        add(_label(_LEFT + _PLOT / 2, top + 32, "robot time (s)", 11, "middle"))
        return top + 40

    def _legend(self, top: int) -> int:
        labels = self.timeline.states()[:_MAX_LEGEND]
        add = self.parts.append
        width = _PLOT / _LEGEND_COLUMNS
        for index, label in enumerate(labels):
            x = _LEFT + (index % _LEGEND_COLUMNS) * width
            y = top + (index // _LEGEND_COLUMNS) * _LEGEND_ROW
            add(
                f'<rect x="{x:.1f}" y="{y}" width="12" height="12" '
                f'class="{state_key(label)}" fill="{fallback_color(label)}"/>'
            )
            add(_label(f"{x + 16:.1f}", y + 10, label, 10))
        rows = -(-len(labels) // _LEGEND_COLUMNS)
        return top + rows * _LEGEND_ROW + 6


def _value_axis(signal: Signal) -> tuple[float, float, list[tuple[float, str]]]:
    """The value range of a signal's strip and its labelled ticks: a flag is 0/1 with
    False/True, a constant gets room around it."""
    if signal.flag:
        return -0.15, 1.15, [(0.0, "False"), (1.0, "True")]
    values = signal.value or (0.0,)
    low, high = min(values), max(values)
    if high - low < 1e-12:
        pad = max(abs(low) * 0.1, 1.0)
        low, high = low - pad, high + pad
    ticks = _ticks(low, high, 4)
    margin = (high - low) * 0.05
    return low - margin, high + margin, [(tick, f"{tick:g}") for tick in ticks]


def _ticks(low: float, high: float, count: int) -> list[float]:
    """About ``count`` round values (1, 2 or 5 times a power of ten apart) in [low, high]."""
    raw = (high - low) / max(count, 1)
    power = 10 ** math.floor(math.log10(raw)) if raw > 0 else 1.0
    step = next(m * power for m in (1, 2, 5, 10) if m * power >= raw)
    first = math.ceil(low / step)
    return [round(index * step, 10) for index in range(first, math.floor(high / step) + 1)]


def _label(x: object, y: object, text: str, size: int, anchor: str = "", *, fill: str = "") -> str:
    """A ``<text>`` of ``text``, escaped, at ``x`` and ``y`` (as given)."""
    anchor = f' text-anchor="{anchor}"' if anchor else ""
    fill = f' fill="{fill}"' if fill else ""
    text = escape(text, quote=False)
    return f'<text x="{x}" y="{y}"{anchor} font-size="{size}"{fill} {_FONT}>{text}</text>'


def _frame(top: int, height: int) -> str:
    """The frame of a strip of the chart."""
    return (
        f'<rect x="{_LEFT}" y="{top}" width="{_PLOT}" height="{height}" fill="none" stroke="#888"/>'
    )
