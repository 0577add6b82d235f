"""The re-baselining commands for the terminal: ``review`` prompts, and each command
shows the lines of :mod:`beatlog.report.baselines`; the workflow itself is
:mod:`beatlog.suite.maintenance`."""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from rich.console import Console
from rich.markup import escape
from rich.prompt import Prompt
from rich.text import Text

from beatlog.errors import OptionError
from beatlog.report.baselines import render_orphans, render_pending_diff
from beatlog.suite.baseline import expected_path
from beatlog.suite.maintenance import (
    Decision,
    approve,
    decide,
    find_orphans,
    pending_diff,
    pending_specs,
)
from beatlog.suite.policy import require_writable

__all__ = ["approve_command", "print_lines", "report_orphans", "review"]

Ask = Callable[[str], str]
"""Asks the reviewer a question and returns the answer: accept, reject or skip."""


def print_lines(lines: Sequence[Text], console: Console) -> None:
    """Each line on its own, as it is (no markup or highlighting read into paths)."""
    for line in lines:
        console.print(line, highlight=False)


def report_orphans(paths: Sequence[Path], console: Console) -> None:
    """Name expected and pending files whose spec is gone."""
    print_lines(render_orphans(find_orphans(paths)), console)


def review(
    paths: Sequence[Path], console: Console, *, ask: Ask | None = None
) -> tuple[int, int, int]:
    """Show each pending change against the current expectation, and let the reviewer
    accept or reject it: at a terminal by prompting (``a``, ``r`` or ``s`` will do), else
    by reading one answer a line from standard input (a pipe; none left means skip).
    Returns (accepted, rejected, left)."""
    specs = pending_specs(paths)
    report_orphans(paths, console)
    if not specs:
        console.print("nothing pending")
        return 0, 0, 0
    if ask is None:
        ask = _prompt(console) if sys.stdin.isatty() else _piped
    decided = dict.fromkeys(Decision, 0)
    for spec in specs:
        console.print(render_pending_diff(pending_diff(spec)), highlight=False)
        decision = Decision.parse(ask(f"accept the new expectation of {spec.name}?"))
        if decision is not Decision.SKIP:
            require_writable()
        decide(spec, decision)
        decided[decision] += 1
        if decision is Decision.ACCEPT:
            console.print(f"[green]accepted[/] {expected_path(spec.path)}")
        elif decision is Decision.REJECT:
            console.print(f"[red]rejected[/] {spec.name}: pending file removed")
        else:
            console.print(f"left pending: accept with [bold]beatlog approve {spec.path}[/]")
    return decided[Decision.ACCEPT], decided[Decision.REJECT], decided[Decision.SKIP]


_CHOICES = escape("[a]ccept/[r]eject/[s]kip")
"""The choices as the prompt shows them: brackets escaped, or rich reads them as styles."""


def _prompt(console: Console) -> Ask:
    """Ask at the terminal until the answer names a decision (or starts one)."""

    def ask(question: str) -> str:
        while True:
            try:
                answer = Prompt.ask(f"{escape(question)} {_CHOICES}", console=console)
            except EOFError:
                return Decision.SKIP
            try:
                return Decision.parse(answer or Decision.SKIP)
            except OptionError as exc:
                console.print(str(exc), style="yellow")

    return ask


def _piped(question: str) -> str:
    """The next answer from standard input (not a terminal); skip when none is left."""
    answer = sys.stdin.readline().strip()
    return answer or Decision.SKIP


def approve_command(paths: Sequence[Path], console: Console) -> None:
    """Accept every pending baseline given, naming each."""
    for spec in approve(paths):
        console.print(f"[green]approved[/] {spec.name}: {expected_path(spec.path)}")
