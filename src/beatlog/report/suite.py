"""What a suite session did, as the lines a shell shows (the summary table, notes, the
determinism audit, baseline updates, orphans, coverage and closing counts); it never
prints."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from rich.console import Group, RenderableType
from rich.table import Table
from rich.text import Text

from beatlog.report.baselines import render_orphans, render_stale, render_updates
from beatlog.report.console import plain_text, render_suite
from beatlog.report.counts import plural, verdict_counts
from beatlog.report.coverage import render_coverage
from beatlog.suite.runner import SpecOutcome, Verdict

if TYPE_CHECKING:
    from beatlog.analysis.coverage import SuiteCoverage
    from beatlog.audit.replays import AuditReport
    from beatlog.baseline.policy import StaleSuite
    from beatlog.suite.maintenance import PendingUpdate

__all__ = ["NAMED_IN_NOTES", "SuiteReport", "plain_lines", "render_audit", "variant_lines"]

NAMED_IN_NOTES = 5
"""DTCs named in a note before the rest are counted."""


@dataclass(frozen=True, kw_only=True)
class SuiteReport:
    """What a suite session did (see :class:`beatlog.report.session.SuiteSession`)."""

    outcomes: tuple[SpecOutcome, ...] = ()
    """The DTCs that ran to a verdict, in spec order."""
    selected: int = 0
    """The DTCs selected to run: those without an outcome were not run."""
    wall_s: float = 0.0
    """How long the DTCs took to run, all together."""
    audited: bool = False
    """Whether the DTCs' determinism was audited."""
    updates: tuple[PendingUpdate, ...] = ()
    """What updating the baselines did."""
    orphans: tuple[Path, ...] = ()
    """Expected and pending files whose spec is gone."""
    variant_specs: tuple[Path, ...] = ()
    """The specs written for the variants that failed."""
    stale: StaleSuite | None = None
    """How the suite is past its project's open-loop limits, if it is."""
    coverage: SuiteCoverage | None = None
    """The transition coverage, where it was asked for (shown, or written as JSON)."""
    shows_coverage: bool = False
    """Whether the coverage is shown (it may be only written)."""
    warnings: tuple[str, ...] = ()
    """What went wrong without failing the session (the coverage memory's problems)."""
    written: tuple[Path, ...] = ()
    """The report files written."""
    error: str | None = None
    """What ended the session with an error: a report file that could not be written
    (those after it were not written either), or the cluster lost (the outcomes are
    those that came before, and nothing is updated or written)."""
    interrupted: KeyboardInterrupt | None = None
    """What stopped the run (Ctrl-C, or quitting the debugger at a break): the outcomes
    are those complete by then, and no report file is written."""

    @property
    def cycles(self) -> int:
        """The cycles replayed, all DTCs together."""
        return sum(outcome.result.cycles for outcome in self.outcomes if outcome.result)

    @property
    def not_run(self) -> int:
        """The DTCs selected that have no verdict (the run stopped before them)."""
        return self.selected - len(self.outcomes)

    @property
    def exit_code(self) -> int:
        """As ``beatlog test`` exits: 2 when a DTC could not run or a report could not
        be written, 1 when one failed, its audit found something or the suite is stale
        (past its project's open-loop limits), else 0."""
        verdicts = {outcome.verdict for outcome in self.outcomes}
        if Verdict.ERROR in verdicts or self.error is not None:
            return 2
        unsound = any(outcome.audit_findings for outcome in self.outcomes)
        return 1 if Verdict.FAILED in verdicts or unsound or self.stale else 0

    def lines(self, *, every: bool = False) -> list[RenderableType]:
        """Everything the session has to tell but the closing counts, in order (with
        ``every``, the summary table lists every DTC)."""
        return [*self.summary(every=every), *self.baseline_lines(), *self.coverage_lines()]

    def summary(self, *, every: bool = False) -> list[RenderableType]:
        """What ran: the summary table, the notes and the audit's findings."""
        if not self.outcomes:
            return []
        lines: list[RenderableType] = [render_suite(self.outcomes, every=every)]
        lines.extend(self.note_lines())
        if self.audited:
            lines.append(render_audit(self.outcomes))
        return lines

    def baseline_lines(self) -> list[Text]:
        """What updating the baselines did, the orphaned baselines, and how the suite is
        stale."""
        return [
            *render_updates(self.updates),
            *variant_lines(self.variant_specs),
            *self.orphan_lines(),
            *render_stale(self.stale),
        ]

    def note_lines(self) -> list[Text]:
        """What the passing DTCs' replays note (a failure's report has its own), one
        line per note, naming a few of the DTCs it concerns."""
        concerned: dict[str, list[str]] = {}
        for outcome in self.outcomes:
            if outcome.verdict is Verdict.PASSED and outcome.result is not None:
                for note in outcome.result.notes:
                    concerned.setdefault(note, []).append(outcome.spec.label)
        lines = []
        for note, names in concerned.items():
            shown = ", ".join(names[:NAMED_IN_NOTES])
            if len(names) > NAMED_IN_NOTES:
                shown = f"{len(names)} DTCs ({shown} and {len(names) - NAMED_IN_NOTES} more)"
            lines.append(Text(f"note: {shown}: {note}"))
        return lines

    def orphan_lines(self) -> list[Text]:
        """One line per orphaned baseline."""
        return render_orphans(self.orphans)

    def coverage_lines(self) -> list[RenderableType]:
        """The coverage table, when it is shown."""
        if self.coverage is None or not self.shows_coverage:
            return []
        return [render_coverage(self.coverage)]

    def closing_line(self) -> str:
        """``2 passed, 1 failed`` (then the errors, the DTCs not run and those open
        loop), with how long the run took and the cycles it replayed."""
        counts = verdict_counts(
            (outcome.verdict for outcome in self.outcomes),
            not_run=self.not_run,
            open_loop=sum(outcome.open_loop is not None for outcome in self.outcomes),
        )
        cycles = self.cycles
        return f"{counts} in {self.wall_s:.2f} s ({cycles:,} cycle{'' if cycles == 1 else 's'})"


def variant_lines(written: Iterable[Path]) -> list[Text]:
    """One line per spec written for a failing variant (:mod:`beatlog.suite.variants`)."""
    return [
        Text(f"written: {path} (a failing variant, now a DTC of its own: commit it)")
        for path in written
    ]


def plain_lines(lines: Iterable[RenderableType]) -> list[str]:
    """Lines as plain text, for pytest's summary: a line of text as it is, anything
    else (a table) as the terminal would draw it."""
    plain: list[str] = []
    for line in lines:
        if isinstance(line, Text):
            plain.append(line.plain)
        else:
            plain.extend(plain_text(line).splitlines())
    return plain


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
