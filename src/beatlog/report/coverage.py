"""Transition coverage for people: a table for the console and a section for HTML."""

from __future__ import annotations

import html

from rich.table import Table
from rich.text import Text

from beatlog.analysis.coverage import BehaviorCoverage, SuiteCoverage
from beatlog.report.counts import plural

__all__ = ["coverage_html", "render_coverage"]


def _states(cover: BehaviorCoverage) -> str:
    return ", ".join(
        f"{state} ({plural(len(seen.dtcs), 'DTC')}, {plural(seen.cycles, 'cycle')})"
        for state, seen in cover.states.items()
    )


def _transitions(cover: BehaviorCoverage) -> str:
    return "; ".join(
        f"{before} → {after} ×{seen.cycles} in {plural(len(seen.dtcs), 'DTC')}"
        for (before, after), seen in cover.transitions.items()
    )


def _unreached(cover: BehaviorCoverage) -> str:
    """Declared states no DTC reaches, then states earlier runs saw that none reaches now."""
    return ", ".join(
        [
            *cover.unreached,
            *(
                f"{state} (seen before in {', '.join(dtcs) or 'an earlier run'})"
                for state, dtcs in cover.no_longer_reached.items()
            ),
        ]
    )


def render_coverage(coverage: SuiteCoverage) -> Table:
    """One row per behavior: states reached, transitions taken, and the states declared or
    seen by earlier runs that no DTC reaches."""
    table = Table(title="transition coverage", title_justify="left", expand=True)
    table.add_column("behavior", overflow="fold")
    table.add_column("states reached", ratio=2, overflow="fold")
    table.add_column("transitions", ratio=3, overflow="fold")
    table.add_column("unreached", style="yellow", ratio=2, overflow="fold")
    for name, cover in coverage.behaviors.items():
        table.add_row(
            Text(name),
            Text(_states(cover)),
            Text(_transitions(cover) or "none"),
            Text(_unreached(cover)),
        )
    return table


def coverage_html(coverage: SuiteCoverage) -> str:
    """The coverage table as an HTML section."""
    rows = "\n".join(
        "<tr>"
        + "".join(
            f"<td>{html.escape(cell)}</td>"
            for cell in (name, _states(cover), _transitions(cover), _unreached(cover))
        )
        + "</tr>"
        for name, cover in coverage.behaviors.items()
    )
    return (
        '<section id="coverage"><h2>Transition coverage</h2><table>'
        "<tr><th>behavior</th><th>states reached</th><th>transitions</th>"
        f"<th>unreached</th></tr>\n{rows}\n</table></section>"
    )
