"""Writes a suite's outcomes as one self-contained HTML page: no scripts, no network.

A summary table, then a section per DTC: its verdict, first divergence and rerun
command, its charts as inline SVG, and the details. All user data is escaped.
"""

from __future__ import annotations

import html
from collections.abc import Iterable, Sequence
from itertools import zip_longest
from pathlib import Path
from typing import NamedTuple

from beatlog._version import __version__
from beatlog.analysis.coverage import SuiteCoverage
from beatlog.analysis.timeline import Timeline
from beatlog.log.files import replacing
from beatlog.replay.verdict import Divergence, RandomDraw, StateChange
from beatlog.report.console import SUMMARY_COLUMNS
from beatlog.report.counts import verdict_counts
from beatlog.report.coverage import coverage_html
from beatlog.report.svg import state_styles, svg_chart
from beatlog.suite.runner import SpecOutcome

__all__ = ["Chart", "dtc_charts", "write_html"]

_TITLE = "beatlog DTC report"
"""The report's title, in its head and atop its page."""

_CSS = """
body { font: 14px/1.45 system-ui, sans-serif; margin: 1.5em auto; max-width: 1260px;
  padding: 0 1em; color: #222; }
h1 { margin-bottom: 0.2em; }
table { border-collapse: collapse; margin: 0.6em 0; }
th, td { border: 1px solid #ddd; padding: 0.2em 0.6em; text-align: left; vertical-align: top; }
th { background: #f4f4f4; }
caption { text-align: left; font-weight: 600; padding: 0.3em 0; }
code, pre, .value { font-family: ui-monospace, monospace; font-size: 13px; }
pre { background: #f8f8f8; padding: 0.6em; overflow-x: auto; }
section.dtc { border-top: 3px solid #ccc; margin-top: 2em; padding-top: 0.5em; }
section.failed { border-color: #d62728; }
section.passed { border-color: #2ca02c; }
section.error { border-color: #9467bd; }
.verdict { font-weight: 700; text-transform: uppercase; }
.passed .verdict, tr.passed .verdict { color: #2ca02c; }
.failed .verdict, tr.failed .verdict { color: #d62728; }
.error .verdict, tr.error .verdict { color: #9467bd; }
.divergence { background: #fff5f5; border-left: 4px solid #d62728; padding: 0.4em 1em; }
tr.differs td { font-weight: 700; }
tr.here td { background: #ffe8e8; }
figure.timeline { margin: 1em 0; }
figure.timeline svg { max-width: 100%; height: auto; }
dl.facts { display: grid; grid-template-columns: max-content auto; gap: 0.1em 1em; }
dl.facts dt { color: #666; }
dl.facts dd { margin: 0; }
"""


class Chart(NamedTuple):
    """One drawn chart of a DTC."""

    svg: str
    """The ``<svg>`` element."""
    states: tuple[str, ...]
    """The state labels it shows, in order of first appearance (the page colours them)."""
    caption: str


def dtc_charts(name: str, timelines: Sequence[Timeline]) -> tuple[Chart, ...]:
    """The charts of the DTC ``name``: every timeline but the last is a close-up of
    the first divergence."""
    charts = []
    for index, timeline in enumerate(timelines):
        start_s, end_s = timeline.start_ns / 1e9, timeline.end_ns / 1e9
        if index < len(timelines) - 1:
            title = f"{name}: close-up of the first divergence, {start_s:.3f}–{end_s:.3f} s"
        else:
            title = f"{name}: the whole session, {timeline.cycles:,} cycles, {end_s:.1f} s"
        caption = "Behavior states as recorded and as replayed, with robot-state fields" + (
            "; the red line marks the first divergence." if timeline.divergence else "."
        )
        svg = svg_chart(timeline, title=title)
        charts.append(Chart(svg, tuple(timeline.states()), caption))
    return tuple(charts)


def write_html(
    outcomes: Sequence[SpecOutcome], path: str | Path, *, coverage: SuiteCoverage | None = None
) -> None:
    """Write the report of ``outcomes`` to ``path`` (UTF-8), whole or not at all: a
    summary, a section per DTC, then the coverage if given.

    :raises OSError: the file cannot be written.
    """
    counts = verdict_counts(
        (outcome.verdict for outcome in outcomes),
        open_loop=sum(outcome.open_loop is not None for outcome in outcomes),
    )
    charts = [dtc_charts(outcome.spec.label, outcome.timelines) for outcome in outcomes]
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{_TITLE}: {_e(counts)}</title>",
        f"<style>{_CSS}{state_styles(s for drawn in charts for c in drawn for s in c.states)}"
        "</style></head><body>",
        f"<h1>{_TITLE}</h1>",
        f'<p class="counts">{_e(counts)}, {sum(o.result.cycles for o in outcomes if o.result):,} '
        "cycles replayed "
        f"(beatlog {_e(__version__)})</p>",
        _summary_table(outcomes),
    ]
    parts.extend(
        _section(index, outcome, drawn)
        for index, (outcome, drawn) in enumerate(zip(outcomes, charts, strict=True), start=1)
    )
    if coverage is not None:
        parts.append(coverage_html(coverage))
    parts.append("</body></html>\n")
    with replacing(Path(path)) as file:
        file.write("\n".join(parts).encode())


def _e(value: object) -> str:
    """Escape any value for element content and quoted attributes."""
    return html.escape(str(value), quote=True)


def _summary_table(outcomes: Sequence[SpecOutcome]) -> str:
    rows = []
    for index, outcome in enumerate(outcomes, start=1):
        result = outcome.result
        divergence = result.divergence if result else None
        first = outcome.error or ""
        if divergence is not None:
            first = f"cycle {divergence.cycle}, t = {divergence.time_s:.3f} s, {divergence.kind}"
        rows.append(
            _row(
                [
                    f'<a href="#dtc-{index}">{_e(outcome.spec.label)}</a>',
                    f'<span class="verdict">{_e(outcome.verdict_label)}</span>',
                    _e(result.cycles) if result else "—",
                    f"{result.robot_time_s:.1f} s" if result else "—",
                    f"{outcome.wall_time_s:.2f} s",
                    _e(first),
                ],
                css=outcome.verdict.value,
            )
        )
    head = _row(SUMMARY_COLUMNS, cell="th")
    return f'<table class="suite"><thead>{head}</thead><tbody>{"".join(rows)}</tbody></table>'


def _row(cells: Iterable[str], *, cell: str = "td", css: str = "") -> str:
    """A table row of cells that are already markup."""
    attribute = f' class="{css}"' if css else ""
    return f"<tr{attribute}>" + "".join(f"<{cell}>{c}</{cell}>" for c in cells) + "</tr>"


def _section(index: int, outcome: SpecOutcome, charts: Sequence[Chart]) -> str:
    spec = outcome.spec
    verdict = outcome.verdict
    parts = [
        f'<section class="dtc {verdict.value}" id="dtc-{index}">',
        f'<h2><span class="verdict">{_e(verdict)}</span> {_e(spec.label)}</h2>',
        f'<p class="purpose">{_e(spec.purpose)}</p>',
    ]
    rerun = outcome.reproduce
    result = outcome.result
    if result is None:
        parts.append(f'<p class="error">{_e(outcome.error)}</p>')
        if outcome.error_traceback:
            parts.append(f'<pre class="traceback">{_e(outcome.error_traceback)}</pre>')
    elif result.divergence is not None:
        parts.append(_divergence(result.divergence, rerun))
    parts.extend(
        f'<figure class="timeline">{chart.svg}<figcaption>{_e(chart.caption)}</figcaption></figure>'
        for chart in charts
    )
    if result is not None and result.divergence is not None:
        parts.append(_details(result.divergence))
    facts = [
        ("spec", spec.origin),
        ("procedure", " / ".join(spec.procedure)),
        ("log", spec.log_name),
        ("system", spec.system or "the one recorded in the log"),
        ("tags", ", ".join(spec.tags) or "—"),
        ("wall time", f"{outcome.wall_time_s:.3f} s"),
        ("rerun", rerun),
    ]
    if result is not None:
        facts[5:5] = [
            ("cycles", f"{result.cycles:,}"),
            ("robot time", f"{result.robot_time_s:.3f} s"),
            ("log status", result.status.describe() if result.status else "not read to its end"),
        ]
    items = "".join(f"<dt>{_e(name)}</dt><dd>{_e(value)}</dd>" for name, value in facts)
    parts.append(f'<dl class="facts">{items}</dl></section>')
    return "\n".join(parts)


def _divergence(divergence: Divergence, rerun: str) -> str:
    """The part to read first: where, why, what changed, how to rerun."""
    parts = [
        '<div class="divergence">',
        f"<h3>First divergence: cycle {divergence.cycle}, t = {divergence.time_s:.3f} s "
        f"— {_e(divergence.kind)}</h3>",
        f'<p class="message">{_e(divergence.message)}</p>',
    ]
    if divergence.perception:
        parts.append(_side_by_side("robot state from the samples", *divergence.perception_sides))
    if divergence.samples:
        parts.append(f'<p class="samples">samples: {_e(divergence.samples_text)}</p>')
    if divergence.expected or divergence.actual:
        parts.append(
            _side_by_side("behavior state changes", divergence.expected, divergence.actual)
        )
    parts.append(f'<p class="rerun">Rerun just this DTC: <code>{_e(rerun)}</code></p></div>')
    return "\n".join(parts)


def _details(divergence: Divergence) -> str:
    parts = []
    if divergence.expected_outputs or divergence.actual_outputs:
        parts.append(_side_by_side("outputs", *divergence.output_sides))
    if divergence.random_recorded or divergence.random_drawn:
        parts.append(
            _side_by_side("random numbers", divergence.random_recorded, divergence.random_drawn)
        )
    if divergence.context:
        parts.append(_context(divergence))
    if divergence.robot_state:
        parts.append(_values("robot state RS_t", divergence.robot_state))
    if divergence.states:
        parts.append(_values("behavior states after the update", divergence.states))
    if divergence.traceback:
        parts.append(f'<pre class="traceback">{_e(divergence.traceback)}</pre>')
    return "\n".join(parts)


def _values(caption: str, values: dict[str, object]) -> str:
    """Named values, one a row (a robot state, the behaviors' states)."""
    rows = "".join(
        _row([_e(name), f'<span class="value">{_e(repr(value))}</span>'])
        for name, value in values.items()
    )
    return f'<table class="robot-state"><caption>{_e(caption)}</caption>{rows}</table>'


def _side_by_side(
    what: str,
    expected: Sequence[StateChange | RandomDraw | str],
    actual: Sequence[StateChange | RandomDraw | str],
) -> str:
    pairs = [*zip_longest(map(str, expected), map(str, actual), fillvalue="—")]
    rows = [
        _row([_e(want), _e(got)], css="" if want == got else "differs")
        for want, got in pairs or [("—", "—")]
    ]
    head = _row(["recorded", "replayed"], cell="th")
    return f"<table><caption>{_e(what)}</caption>{head}{''.join(rows)}</table>"


def _context(divergence: Divergence) -> str:
    rows = []
    for row in divergence.context:
        here = row.cycle == divergence.cycle
        css = "here" if here else ("differs" if row.expected != row.actual else "")
        rows.append(
            _row(
                [
                    f"▶ {row.cycle}" if here else str(row.cycle),
                    f"{row.time_ns / 1e9:.3f}",
                    "<br>".join(_e(change) for change in row.expected) or "—",
                    "<br>".join(_e(change) for change in row.actual) or "—",
                ],
                css=css,
            )
        )
    head = _row(["cycle", "t (s)", "recorded", "replayed"], cell="th")
    return (
        f'<table class="context"><caption>state changes around it</caption>{head}'
        f"{''.join(rows)}</table>"
    )
