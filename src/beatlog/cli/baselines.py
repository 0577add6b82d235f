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

from beatlog.baseline.file import expected_path
from beatlog.baseline.policy import require_writable
from beatlog.errors import OptionError
from beatlog.report.baselines import (
    loss_text,
    render_losses,
    render_orphans,
    render_pending_diff,
)
from beatlog.suite.maintenance import (
    Decision,
    approve,
    decide,
    find_orphans,
    pending_diff,
    pending_specs,
)

__all__ = ["approve_command", "print_lines", "report_orphans", "review"]

Ask = Callable[[str], str]
"""Asks the reviewer a question (its choices shown in it) and returns the answer typed."""


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
    """Show each pending change against the current expectation, with what it loses,
    and let the reviewer accept or reject it: at a terminal by prompting (``a``, ``r`` or
    ``s`` will do), else by reading one answer a line from standard input (a pipe; none
    left means skip), each question and answer shown. Accepting a change that loses
    something asks about each loss in its own words; one not accepted leaves the change
    pending. Returns (accepted, rejected, left)."""
    specs = pending_specs(paths)
    report_orphans(paths, console)
    if not specs:
        console.print("nothing pending")
        return 0, 0, 0
    if ask is None:
        ask = _prompt(console) if sys.stdin.isatty() else _piped(console)
    decided = dict.fromkeys(Decision, 0)
    for spec in specs:
        diff = pending_diff(spec)
        console.print(render_pending_diff(diff), highlight=False)
        decision = _decision(ask, f"accept the new expectation of {spec.name}?", console)
        kept = decision is not Decision.ACCEPT or all(
            ask(f"{loss_text(loss)}: accept this loss? [y/N]").strip().lower() in ("y", "yes")
            for loss in diff.shift.losses
        )
        if not kept:
            decision = Decision.SKIP
        if decision is not Decision.SKIP:
            require_writable()
        decide(spec, decision)
        decided[decision] += 1
        if decision is Decision.ACCEPT:
            console.print(f"[green]accepted[/] {expected_path(spec.path)}")
        elif decision is Decision.REJECT:
            console.print(f"[red]rejected[/] {spec.name}: pending file removed")
        else:
            why = "" if kept else "a loss was not accepted; "
            console.print(f"left pending: {why}accept with [bold]beatlog approve {spec.path}[/]")
    return decided[Decision.ACCEPT], decided[Decision.REJECT], decided[Decision.SKIP]


_CHOICES = "[a]ccept/[r]eject/[s]kip"


def _decision(ask: Ask, question: str, console: Console) -> Decision:
    """Ask until the answer names a decision (or starts one); none is skip."""
    while True:
        answer = ask(f"{question} {_CHOICES}")
        try:
            return Decision.parse(answer or Decision.SKIP)
        except OptionError as exc:
            console.print(str(exc), style="yellow")


def _prompt(console: Console) -> Ask:
    """Ask at the terminal; the end of input answers nothing."""

    def ask(question: str) -> str:
        try:
            # the question escaped, or rich reads its brackets as styles
            return Prompt.ask(escape(question), console=console)
        except EOFError:
            return ""

    return ask


def _piped(console: Console) -> Ask:
    """Read the next answer from standard input (not a terminal), showing the question
    and the answer as a terminal would; none left answers nothing."""

    def ask(question: str) -> str:
        answer = sys.stdin.readline().strip()
        console.print(f"{question}: {answer}".rstrip(), markup=False, highlight=False)
        return answer

    return ask


def approve_command(paths: Sequence[Path], console: Console) -> None:
    """Accept every pending baseline given, naming each and each loss it accepts."""
    approved = approve(paths)
    if not approved:
        console.print("nothing pending to approve", highlight=False)
    for spec, weighed in approved:
        console.print(f"[green]approved[/] {spec.name}: {expected_path(spec.path)}")
        print_lines(render_losses(weighed, f"  accepted loss in {spec.name}: "), console)
