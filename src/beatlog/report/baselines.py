"""The re-baselining workflow for people: what an update did, orphaned baselines, and a
pending expectation as a coloured diff. Lines only; the CLI and the pytest plugin show them."""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from pathlib import Path

from rich.console import Group, RenderableType
from rich.rule import Rule
from rich.text import Text

from beatlog.report.counts import plural
from beatlog.suite.approved import Approved
from beatlog.suite.baseline import pending_path
from beatlog.suite.maintenance import PendingDiff, PendingUpdate, RebuiltRun, UpdateAction

__all__ = [
    "open_loop_text",
    "render_approved",
    "render_orphans",
    "render_pending_diff",
    "render_updates",
]

_DIFF_STYLES = {"+": "green", "-": "red", "@": "cyan"}
_MAX_RUNS = 20
"""The runs of rebuilt robot states a review sums up; a file with more names them all."""


def render_updates(updates: Sequence[PendingUpdate]) -> list[Text]:
    """One line per pending file written, refused or removed, saying how to go on; one
    line for all the failures whose expectation ``CI`` withheld."""
    lines: list[Text] = []
    if any(update.action is UpdateAction.WITHHELD for update in updates):
        lines.append(Text("CI is set: no pending baselines written", style="yellow"))
    for update in updates:
        spec = update.spec
        if update.action is UpdateAction.WRITTEN:
            lines.append(
                Text.assemble(
                    ("pending", "cyan"),
                    f" {update.path} ({update.state_changes} state changes, "
                    f"{update.output_changes} output changes{_fields(update)}): review with ",
                    (f"beatlog review {spec.path}", "bold"),
                    ", accept with ",
                    (f"beatlog approve {spec.path}", "bold"),
                )
            )
        elif update.action is UpdateAction.REFUSED:
            lines.append(
                Text.assemble(("not updated", "yellow"), f" {spec.label}: {update.reason}")
            )
        elif update.action is UpdateAction.REMOVED:
            lines.append(
                Text.assemble(("removed stale", "cyan"), f" {update.path}: {spec.label} passes")
            )
    return lines


def _fields(update: PendingUpdate) -> str:
    count = update.robot_state_cycles
    rebuilt = f", robot state rebuilt otherwise in {plural(count, 'cycle')}" if count else ""
    drawn = sum(len(rule.cycles) for rule in update.draws)
    return (
        rebuilt
        + (f", {plural(drawn, 'draw')} made otherwise" if drawn else "")
        + (f", {open_loop_text(update.open_loop)}" if update.open_loop else "")
    )


def open_loop_text(open_loop: tuple[int, int]) -> str:
    """Where the behaviors left the recording: ``open loop since cycle 517 (15.510 s)``."""
    cycle, time_ns = open_loop
    return f"open loop since cycle {cycle} ({time_ns / 1e9:.3f} s)"


def render_approved(approved: Approved) -> Text:
    """The approved baseline a log is judged against, and where it goes open loop."""
    baseline = approved.baseline
    open_loop = baseline.expectation.open_loop
    return Text.assemble(
        ("approved baseline", "cyan"),
        f" {baseline.path.name} (spec {approved.spec.path.name})",
        ": " + (open_loop_text(open_loop) if open_loop else "closed loop, as recorded"),
    )


def render_orphans(orphans: Iterable[Path]) -> list[Text]:
    """One line per expected or pending file whose spec is gone."""
    return [
        Text.assemble(("orphaned baseline", "yellow"), f" {orphan}: no spec beside it; delete it")
        for orphan in orphans
    ]


def _value(value: object) -> str:
    return json.dumps(value, default=repr)


def _run_line(run: RebuiltRun) -> Text:
    """``robot state "speed" rebuilt otherwise in cycles 517–4999 (4483 cycles), first:
    "speed" 0.04 → 0.041``."""
    first: list[str | tuple[str, str]] = []
    for difference in run.first:
        first.extend(
            [
                ", " if first else "",
                f"{json.dumps(difference.field)} ",
                (_value(difference.recorded), "red"),
                " → ",
                (_value(difference.rebuilt), "green"),
            ]
        )
    return Text.assemble(
        ("robot state ", "cyan"),
        f"{', '.join(json.dumps(name) for name in run.fields)} rebuilt otherwise in cycles "
        f"{run.first_cycle}–{run.last_cycle} ({plural(run.cycles, 'cycle')}), first: ",
        *first,
    )


def render_pending_diff(diff: PendingDiff, *, max_lines: int = 200) -> RenderableType:
    """The pending expectation against today's, at most ``max_lines`` lines of diff."""
    spec = diff.spec
    parts: list[RenderableType] = [
        Rule(f"{spec.name} ({spec.path})"),
        Text(f"{diff.old_lines} state and output changes {diff.source} → {diff.new_lines} pending"),
        *(
            Text.assemble(
                ("robot state ", "cyan"),
                f"{json.dumps(change.field)} rebuilt otherwise in "
                f"{plural(change.cycles, 'cycle')}, first in cycle {change.first_cycle}: ",
                (_value(change.before), "red"),
                " → ",
                (_value(change.after), "green"),
            )
            for change in diff.robot_states
        ),
        *(_run_line(run) for run in diff.rebuilt_runs[:_MAX_RUNS]),
        *(Text.assemble(("draws ", "cyan"), str(rule)) for rule in diff.draws),
        *(
            [Text(open_loop_text(diff.open_loop), style="yellow")]
            if diff.open_loop is not None
            else []
        ),
    ]
    if len(diff.rebuilt_runs) > _MAX_RUNS:
        more = len(diff.rebuilt_runs) - _MAX_RUNS
        parts.append(Text(f"… {plural(more, 'more run')}: read {pending_path(spec.path)}"))
    parts.extend(
        Text(line, style=_DIFF_STYLES.get(line[:1], "")) for line in diff.lines[:max_lines]
    )
    if len(diff.lines) > max_lines:
        parts.append(
            Text(
                f"… {len(diff.lines) - max_lines} more diff lines: read {pending_path(spec.path)}",
                style="dim",
            )
        )
    return Group(*parts)
