"""The baseline commands: ``beatlog review`` shows each pending baseline change and asks
whether to accept it, ``beatlog approve`` accepts the pending baselines of DTC specs, and
``beatlog upgrade-baselines`` rewrites baselines of older formats in the current one.
Each shows the lines of :mod:`beatlog.report.baselines`; the workflow itself is
:mod:`beatlog.suite.maintenance`."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from beatlog.cli.common import EXIT_OK
from beatlog.errors import OptionError

if TYPE_CHECKING:
    from rich.console import Console

    from beatlog.suite.maintenance import Decision

__all__ = [
    "add_approve_arguments",
    "review",
    "run_approve",
    "run_review",
    "run_upgrade",
]

Ask = Callable[[str], str]
"""Asks the reviewer a question (its choices shown in it) and returns the answer typed."""
_CHOICES = "[a]ccept/[r]eject/[s]kip"


def run_review(args: argparse.Namespace, console: Console) -> int:
    """Review what is pending (see :func:`review`)."""
    review(args.paths, console)
    return EXIT_OK


def review(
    paths: Sequence[Path], console: Console, *, ask: Ask | None = None
) -> tuple[int, int, int]:
    """Show each pending change against the current baseline, with what it loses,
    and let the reviewer accept or reject it: at a terminal by prompting (``a``, ``r`` or
    ``s`` will do), else by reading one answer a line from standard input (a pipe; none
    left means skip), each question and answer shown. Accepting a change that loses
    something asks about each loss in its own words; one not accepted leaves the change
    pending. Expected and pending files whose spec is gone are named first. Returns
    (accepted, rejected, left)."""
    from rich.markup import escape

    from beatlog.baseline.file import expected_path
    from beatlog.baseline.policy import require_writable
    from beatlog.report.baselines import loss_text, render_orphans, render_pending_diff
    from beatlog.suite.maintenance import (
        Decision,
        decide,
        find_orphans,
        pending_diff,
        pending_specs,
    )

    specs = pending_specs(paths)
    for line in render_orphans(find_orphans(paths)):
        console.print(line, highlight=False)
    if not specs:
        console.print("nothing pending")
        return 0, 0, 0
    ask = ask or _asking(console)
    decided = dict.fromkeys(Decision, 0)
    for spec in specs:
        diff = pending_diff(spec)
        console.print(render_pending_diff(diff), highlight=False)
        decision = _decision(ask, f"accept the new baseline of {spec.name}?", console)
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
            console.print(f"[green]accepted[/] {escape(str(expected_path(spec.path)))}")
        elif decision is Decision.REJECT:
            console.print(f"[red]rejected[/] {escape(spec.name)}: pending file removed")
        else:
            why = "" if kept else "a loss was not accepted; "
            console.print(
                f"left pending: {why}accept with [bold]beatlog approve {escape(str(spec.path))}[/]"
            )
    return decided[Decision.ACCEPT], decided[Decision.REJECT], decided[Decision.SKIP]


def _decision(ask: Ask, question: str, console: Console) -> Decision:
    """Ask until the answer names a decision (or starts one); none is skip."""
    from beatlog.suite.maintenance import Decision

    while True:
        answer = ask(f"{question} {_CHOICES}")
        try:
            return Decision.parse(answer or Decision.SKIP)
        except OptionError as exc:
            console.print(str(exc), style="yellow")


def _asking(console: Console) -> Ask:
    """Ask at a terminal by prompting, else read the next answer from standard input (a
    pipe), showing the question and the answer as a terminal would; the end of input
    answers nothing."""
    from rich.markup import escape
    from rich.prompt import Prompt

    terminal = sys.stdin.isatty()

    def ask(question: str) -> str:
        if terminal:
            try:  # the question escaped, or rich reads its brackets as styles
                return Prompt.ask(escape(question), console=console)
            except EOFError:
                return ""
        answer = sys.stdin.readline().strip()
        console.print(f"{question}: {answer}".rstrip(), markup=False, highlight=False)
        return answer

    return ask


def add_approve_arguments(approve: argparse.ArgumentParser) -> None:
    """The arguments of ``beatlog approve``."""
    approve.add_argument(
        "paths", nargs="+", type=Path, help="specs or folders whose pending baselines to accept"
    )


def run_approve(args: argparse.Namespace, console: Console) -> int:
    """Accept every pending baseline under the paths without asking, naming each and each
    loss it accepts."""
    from rich.markup import escape

    from beatlog.baseline.file import expected_path
    from beatlog.report.baselines import render_losses
    from beatlog.suite.maintenance import approve

    approved = approve(args.paths)
    if not approved:
        console.print("nothing pending to approve", highlight=False)
    for spec, weighed in approved:
        console.print(
            f"[green]approved[/] {escape(spec.name)}: {escape(str(expected_path(spec.path)))}"
        )
        for line in render_losses(weighed, f"  accepted loss in {spec.name}: "):
            console.print(line, highlight=False)
    return EXIT_OK


def run_upgrade(args: argparse.Namespace, console: Console) -> int:
    """Upgrade each older baseline given, naming each and the format it had."""
    from rich.markup import escape

    from beatlog.baseline.upgrade import upgrade_baselines
    from beatlog.baseline.write import FORMAT

    upgraded = upgrade_baselines(args.paths, _recording)
    if not upgraded:
        console.print("no baseline of an older format", highlight=False)
    for path, version in upgraded:
        console.print(
            f"[green]upgraded[/] {escape(str(path))}: format {version} -> {FORMAT}", highlight=False
        )
    return EXIT_OK


def _recording(baseline: Path, log_name: str) -> Path:
    """The recording its spec names, else the one named ``log_name`` beside it."""
    from beatlog.baseline.file import spec_path
    from beatlog.suite.spec import load_spec

    spec = spec_path(baseline)
    return load_spec(spec).log if spec.is_file() else baseline.with_name(log_name)
