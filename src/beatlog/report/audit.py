"""The determinism audit of a suite for the terminal: each DTC's findings, then a count."""

from __future__ import annotations

from collections.abc import Sequence

from rich.console import Group, RenderableType
from rich.table import Table
from rich.text import Text

from beatlog.audit.replays import AuditReport
from beatlog.report.counts import plural
from beatlog.suite.runner import SpecOutcome

__all__ = ["render_audit"]


def render_audit(outcomes: Sequence[SpecOutcome]) -> RenderableType:
    """The findings of every audited DTC that has any, and a line counting them."""
    audited = [(outcome, outcome.audit) for outcome in outcomes if outcome.audit is not None]
    unsound = [(outcome, report) for outcome, report in audited if not report.ok]
    parts: list[RenderableType] = [
        Group(
            Text.assemble(
                ("AUDIT ", "bold yellow"), f"{outcome.spec.label} ({outcome.spec.origin})"
            ),
            _findings(report),
        )
        for outcome, report in unsound
    ]
    problems = sum(outcome.audit_findings for outcome, _ in unsound)
    if problems:
        parts.append(
            Text(
                f"determinism audit: {plural(problems, 'finding')} "
                f"in {len(unsound)} of {plural(len(audited), 'DTC')}",
                style="bold yellow",
            )
        )
    elif audited:
        seeds = " and ".join(str(run.hash_seed) for run in audited[0][1].runs)
        parts.append(
            Text(
                f"determinism audit: no findings in {plural(len(audited), 'DTC')} "
                f"(each replayed with PYTHONHASHSEED={seeds})",
                style="green",
            )
        )
    return Group(*parts)


def _findings(report: AuditReport) -> RenderableType:
    """One audit's findings as a table of call, site and count, then any hash seed problem."""
    parts: list[RenderableType] = []
    if report.findings:
        table = Table()
        table.add_column("call", style="yellow")
        table.add_column("site")
        table.add_column("calls", justify="right")
        for finding in report.findings:
            site = finding.site if finding.via is None else f"{finding.site}\nfrom {finding.via}"
            table.add_row(finding.call, site, f"{finding.count:,}")
        parts.append(table)
    if report.hash_seed_dependence is not None:
        parts.append(Text(report.hash_seed_dependence, style="yellow"))
    return Group(*parts)
