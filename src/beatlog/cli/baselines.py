"""The re-baselining workflow: ``test --update`` writes pending files, ``review`` shows and
decides them, ``approve`` accepts them. Nothing is ever written when ``CI`` is set."""

from __future__ import annotations

import difflib
import sys
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

from rich.console import Console
from rich.prompt import Prompt
from rich.text import Text

from beatlog.analysis.trace import TracedChange, recorded_outputs, recorded_trace
from beatlog.errors import BaselineError, BeatlogError
from beatlog.suite.baseline import (
    expected_path,
    find_orphans,
    format_lines,
    in_ci,
    log_digest,
    pending_path,
    read_baseline,
    write_baseline,
)
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.spec import DtcSpec, discover_specs

__all__ = ["approve", "report_orphans", "review", "write_pending"]

Ask = Callable[[str], str]
"""Asks the reviewer a question and returns the answer: accept, reject or skip."""


class CiWriteError(BeatlogError):
    """A command that would write a baseline, run in CI."""

    def __init__(self) -> None:
        super().__init__("CI is set: beatlog never writes baselines in CI")


def write_pending(outcomes: Iterable[SpecOutcome], console: Console) -> None:
    """Write the new expectation (state changes and outputs) of every failed DTC to its
    pending file.

    A passing DTC's pending file is stale and removed; accepted baselines are never
    touched. In CI nothing is written.
    """
    outcomes = list(outcomes)
    if in_ci():
        if any(outcome.update for outcome in outcomes):
            console.print("[yellow]CI is set: no pending baselines written")
        return
    for outcome in outcomes:
        spec = outcome.spec
        pending = pending_path(spec.path)
        if outcome.update is not None:
            update = outcome.update
            write_baseline(pending, spec_name=spec.name, log=spec.log, expectation=update)
            console.print(
                f"[cyan]pending[/] {pending} ({len(update.changes)} state changes, "
                f"{len(update.outputs or ())} output changes): "
                f"review with [bold]beatlog review {spec.path}[/], "
                f"accept with [bold]beatlog approve {spec.path}[/]"
            )
        elif outcome.update_refused is not None:
            console.print(f"[yellow]not updated[/] {spec.name}: {outcome.update_refused}")
        elif outcome.verdict is Verdict.PASSED and pending.exists():
            pending.unlink()
            console.print(f"[cyan]removed stale[/] {pending}: {spec.name} passes")


def report_orphans(paths: Sequence[Path], console: Console) -> None:
    """Name expected and pending files whose spec is gone."""
    for orphan in find_orphans(paths):
        console.print(f"[yellow]orphaned baseline[/] {orphan}: no spec beside it; delete it")


def review(
    paths: Sequence[Path], console: Console, *, ask: Ask | None = None
) -> tuple[int, int, int]:
    """Show each pending change against the current expectation, and let the reviewer
    accept or reject it (skipped without a terminal). Returns (accepted, rejected, left)."""
    specs = [spec for spec in discover_specs(paths) if pending_path(spec.path).exists()]
    report_orphans(paths, console)
    if not specs:
        console.print("nothing pending")
        return 0, 0, 0
    if ask is None and sys.stdin.isatty():
        ask = _prompt(console)
    if ask is not None and in_ci():
        raise CiWriteError
    accepted = rejected = 0
    for spec in specs:
        _show_pending(spec, console)
        answer = ask(f"accept the new expectation of {spec.name}?") if ask else "skip"
        if answer == "accept":
            _accept(spec)
            accepted += 1
            console.print(f"[green]accepted[/] {expected_path(spec.path)}")
        elif answer == "reject":
            pending_path(spec.path).unlink()
            rejected += 1
            console.print(f"[red]rejected[/] {spec.name}: pending file removed")
        else:
            console.print(f"left pending: accept with [bold]beatlog approve {spec.path}[/]")
    return accepted, rejected, len(specs) - accepted - rejected


def _prompt(console: Console) -> Ask:
    def ask(question: str) -> str:
        try:
            return Prompt.ask(
                question, console=console, choices=["accept", "reject", "skip"], default="skip"
            )
        except EOFError:
            return "skip"

    return ask


def approve(paths: Sequence[Path], console: Console) -> int:
    """Accept the pending baseline of every spec given (or found in the folders given)."""
    if in_ci():
        raise CiWriteError
    specs = discover_specs(paths)
    waiting = [spec for spec in specs if pending_path(spec.path).exists()]
    if not waiting:
        where = " ".join(str(path) for path in paths)
        raise BaselineError(
            paths[0] if len(paths) == 1 else Path(where),
            "nothing pending to approve (run 'beatlog test --update' first)",
        )
    for spec in waiting:
        _accept(spec)
        console.print(f"[green]approved[/] {spec.name}: {expected_path(spec.path)}")
    return len(waiting)


def _accept(spec: DtcSpec) -> None:
    pending = pending_path(spec.path)
    baseline = read_baseline(pending)  # a damaged pending file must not become the baseline
    if baseline.log_digest != log_digest(spec.log):
        raise BaselineError(pending, f"made from another recording than {spec.log.name}")
    pending.replace(expected_path(spec.path))


def _show_pending(spec: DtcSpec, console: Console, *, max_lines: int = 200) -> None:
    """The pending expectation as a diff against today's: approved, else recorded.

    State changes and output changes interleave by cycle; only the changed cycles and
    a line of context either side are shown, at most ``max_lines`` lines.
    """
    expected = expected_path(spec.path)
    if expected.exists():
        approved = read_baseline(expected)
        old = format_lines(approved.changes, approved.outputs)
        source = f"approved ({expected.name})"
        if approved.outputs is None:
            source += ", no outputs pinned"
    else:
        renamed = spec.comparison.renamed
        old = format_lines(
            (TracedChange(c.cycle, c.time_ns, renamed(c.change)) for c in recorded_trace(spec.log)),
            recorded_outputs(spec.log),
        )
        source = f"recorded ({spec.log.name})"
    pending = read_baseline(pending_path(spec.path))
    new = format_lines(pending.changes, pending.outputs)
    console.rule(f"{spec.name} ({spec.path})")
    console.print(f"{len(old)} state and output changes {source} → {len(new)} pending")
    diff = list(difflib.unified_diff(old, new, source, "pending", n=1, lineterm=""))
    for line in diff[:max_lines]:
        style = {"+": "green", "-": "red", "@": "cyan"}.get(line[:1], "")
        console.print(Text(line, style=style))
    if len(diff) > max_lines:
        console.print(
            f"… {len(diff) - max_lines} more diff lines: read {pending_path(spec.path)}",
            style="dim",
        )
