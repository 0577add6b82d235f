"""The re-baselining commands for the terminal: ``test --update``, ``review`` and
``approve`` render and prompt; the workflow itself is :mod:`beatlog.suite.maintenance`."""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from rich.console import Console
from rich.prompt import Prompt
from rich.text import Text

from beatlog.suite.baseline import expected_path, pending_path
from beatlog.suite.maintenance import (
    Decision,
    PendingDiff,
    PendingUpdate,
    UpdateAction,
    approve,
    decide,
    find_orphans,
    pending_diff,
    pending_specs,
)
from beatlog.suite.policy import require_writable

__all__ = ["approve_command", "render_updates", "report_orphans", "review"]

Ask = Callable[[str], str]
"""Asks the reviewer a question and returns the answer: accept, reject or skip."""


def render_updates(updates: Sequence[PendingUpdate], console: Console) -> None:
    """Say what ``test --update`` did with each pending baseline, and how to go on."""
    if any(update.action is UpdateAction.WITHHELD for update in updates):
        console.print("[yellow]CI is set: no pending baselines written")
    for update in updates:
        spec = update.spec
        if update.action is UpdateAction.WRITTEN:
            console.print(
                f"[cyan]pending[/] {update.path} ({update.state_changes} state changes, "
                f"{update.output_changes} output changes): "
                f"review with [bold]beatlog review {spec.path}[/], "
                f"accept with [bold]beatlog approve {spec.path}[/]"
            )
        elif update.action is UpdateAction.REFUSED:
            console.print(f"[yellow]not updated[/] {spec.name}: {update.reason}")
        elif update.action is UpdateAction.REMOVED:
            console.print(f"[cyan]removed stale[/] {update.path}: {spec.name} passes")


def report_orphans(paths: Sequence[Path], console: Console) -> None:
    """Name expected and pending files whose spec is gone."""
    for orphan in find_orphans(paths):
        console.print(f"[yellow]orphaned baseline[/] {orphan}: no spec beside it; delete it")


def review(
    paths: Sequence[Path], console: Console, *, ask: Ask | None = None
) -> tuple[int, int, int]:
    """Show each pending change against the current expectation, and let the reviewer
    accept or reject it (skipped without a terminal). Returns (accepted, rejected, left)."""
    specs = pending_specs(paths)
    report_orphans(paths, console)
    if not specs:
        console.print("nothing pending")
        return 0, 0, 0
    if ask is None and sys.stdin.isatty():
        ask = _prompt(console)
    if ask is not None:
        require_writable()
    decided = dict.fromkeys(Decision, 0)
    for spec in specs:
        _show(pending_diff(spec), console)
        answer = ask(f"accept the new expectation of {spec.name}?") if ask else Decision.SKIP
        decision = Decision.parse(answer)
        decide(spec, decision)
        decided[decision] += 1
        if decision is Decision.ACCEPT:
            console.print(f"[green]accepted[/] {expected_path(spec.path)}")
        elif decision is Decision.REJECT:
            console.print(f"[red]rejected[/] {spec.name}: pending file removed")
        else:
            console.print(f"left pending: accept with [bold]beatlog approve {spec.path}[/]")
    return decided[Decision.ACCEPT], decided[Decision.REJECT], decided[Decision.SKIP]


def _prompt(console: Console) -> Ask:
    def ask(question: str) -> str:
        try:
            return Prompt.ask(
                question, console=console, choices=[str(d) for d in Decision], default="skip"
            )
        except EOFError:
            return Decision.SKIP

    return ask


def approve_command(paths: Sequence[Path], console: Console) -> None:
    """Accept every pending baseline given, naming each."""
    for spec in approve(paths):
        console.print(f"[green]approved[/] {spec.name}: {expected_path(spec.path)}")


def _show(diff: PendingDiff, console: Console, *, max_lines: int = 200) -> None:
    """The diff, coloured, at most ``max_lines`` lines of it."""
    spec = diff.spec
    console.rule(f"{spec.name} ({spec.path})")
    console.print(
        f"{diff.old_lines} state and output changes {diff.source} → {diff.new_lines} pending"
    )
    for line in diff.lines[:max_lines]:
        style = {"+": "green", "-": "red", "@": "cyan"}.get(line[:1], "")
        console.print(Text(line, style=style))
    if len(diff.lines) > max_lines:
        console.print(
            f"… {len(diff.lines) - max_lines} more diff lines: read {pending_path(spec.path)}",
            style="dim",
        )
