"""Transition coverage for people: a table for the console and a section for HTML."""

from __future__ import annotations

import html

from rich.table import Table
from rich.text import Text

from beatlog.analysis.coverage import SuiteCoverage
from beatlog.report.counts import plural

__all__ = ["BETWEEN_HEARTBEATS", "coverage_html", "render_coverage"]

CHANGES = "changes between heartbeats"
"""The column of the pairs (before → after) a behavior's logged state changes make."""
BETWEEN_HEARTBEATS = (
    "a change between heartbeats is a behavior's state at one heartbeat → its state at "
    "the next: a state passed through within one heartbeat is not logged "
    "(2 → 3 → 1 in one heartbeat shows as 2 → 1)"
)
"""What the pairs are, and are not: the log holds each behavior's state once a heartbeat,
so a pair is no transition the code need have."""


def _columns(coverage: SuiteCoverage) -> list[str]:
    """The table's columns, led by the system when the run covers more than one."""
    several = ["system"] if len(coverage.systems) > 1 else []
    return [*several, "behavior", "states reached", CHANGES, "unreached"]


def _rows(coverage: SuiteCoverage) -> list[list[str]]:
    """One row per behavior, under :func:`_columns`: its states reached, its changes
    between heartbeats, the declared states no DTC reaches, then the states earlier runs
    saw that none reaches now."""
    rows = []
    for cover in coverage.behaviors:
        states = (
            f"{state} ({plural(len(seen.dtcs), 'DTC')}, {plural(seen.cycles, 'cycle')})"
            for state, seen in cover.states.items()
        )
        changes = (
            f"{before} → {after} ×{seen.cycles} in {plural(len(seen.dtcs), 'DTC')}"
            for (before, after), seen in cover.transitions.items()
        )
        gone = (
            f"{state} (seen before in {', '.join(map(coverage.label, dtcs)) or 'an earlier run'})"
            for state, dtcs in cover.no_longer_reached.items()
        )
        system = [cover.system] if len(coverage.systems) > 1 else []
        unreached = ", ".join([*cover.unreached, *gone])
        rows.append(
            [*system, cover.behavior, ", ".join(states), "; ".join(changes) or "none", unreached]
        )
    return rows


_RATIOS = {"states reached": 2, CHANGES: 3, "unreached": 2}


def render_coverage(coverage: SuiteCoverage) -> Table:
    """One row per behavior: states reached, changes between heartbeats, and the states
    declared or seen by earlier runs that no DTC reaches; with more than one system, which
    one each behavior is of. The caption says what a change between heartbeats is."""
    table = Table(
        title="transition coverage",
        title_justify="left",
        caption=BETWEEN_HEARTBEATS,
        caption_justify="left",
        expand=True,
    )
    for column in _columns(coverage):
        style = "yellow" if column == "unreached" else ""
        table.add_column(column, style=style, ratio=_RATIOS.get(column), overflow="fold")
    for row in _rows(coverage):
        table.add_row(*map(Text, row))
    return table


def coverage_html(coverage: SuiteCoverage) -> str:
    """The coverage table as an HTML section."""
    head = "".join(f"<th>{column}</th>" for column in _columns(coverage))
    rows = "\n".join(
        "<tr>" + "".join(f"<td>{html.escape(cell)}</td>" for cell in row) + "</tr>"
        for row in _rows(coverage)
    )
    return (
        '<section id="coverage"><h2>Transition coverage</h2><table>'
        f"<tr>{head}</tr>\n{rows}\n</table><p>{html.escape(BETWEEN_HEARTBEATS)}</p></section>"
    )
