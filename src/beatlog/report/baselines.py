"""The re-baselining workflow for people: what an update did, orphaned baselines, and a
pending baseline as a coloured diff. Lines only; the CLI and the pytest plugin show them."""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

from rich.console import Group, RenderableType
from rich.rule import Rule
from rich.text import Text

from beatlog.analysis.shift import Loss, LossKind, Shift
from beatlog.baseline.file import pending_path
from beatlog.baseline.policy import StaleSuite
from beatlog.replay.approved_state_lines import ApprovedRun
from beatlog.replay.baseline import Baseline
from beatlog.report.counts import plural
from beatlog.suite.approved import Approved
from beatlog.suite.maintenance import PendingDiff, PendingUpdate, UpdateAction

__all__ = [
    "closed_loop_text",
    "loss_text",
    "open_loop_text",
    "render_approved",
    "render_losses",
    "render_orphans",
    "render_pending_diff",
    "render_stale",
    "render_updates",
]

_DIFF_STYLES = {"+": "green", "-": "red", "@": "cyan"}
_MAX_RUNS = 20
"""The runs of rebuilt robot states a review sums up; a file with more names them all."""
_SHOWN_CYCLES = 10
"""The cycles a loss names before it counts the rest."""


def render_updates(updates: Sequence[PendingUpdate]) -> list[Text]:
    """One line per pending file written, refused or removed, saying how to go on, and
    under a pending file a line per loss; one line for all the failures whose
    new baseline ``CI`` withheld."""
    lines: list[Text] = []
    if any(update.action is UpdateAction.WITHHELD for update in updates):
        lines.append(Text("CI is set: no pending baselines written", style="yellow"))
    for update in updates:
        spec = update.spec
        if update.action is UpdateAction.WRITTEN:
            lines.append(
                Text.assemble(
                    ("pending", "cyan"),
                    f" {update.path} ({_counts(update.shift)}{_fields(update)}): review with ",
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
        if update.action in (UpdateAction.WRITTEN, UpdateAction.WITHHELD):
            lines.extend(render_losses(update.shift, f"  lost in {spec.label}: "))
    return lines


def _counts(weighed: Shift | None, then: str = ", ") -> str:
    """``3 state changes lost, 0 new, 2 moved``, and ``then``."""
    if weighed is None:
        return ""
    lost = plural(weighed.lost, "state change")
    return f"{lost} lost, {weighed.gained} new, {weighed.moved} moved{then}"


def render_losses(weighed: Shift | None, lead: str) -> list[Text]:
    """A line per loss, each after ``lead``."""
    if weighed is None:
        return []
    return [Text.assemble((lead, "red"), loss_text(loss)) for loss in weighed.losses]


def loss_text(loss: Loss) -> str:
    """A loss in its own words: ``"escape": 3 state changes no longer happen (cycles
    291, 325, 367); it never changes state in this DTC any more``."""
    name, count = json.dumps(loss.name), len(loss.cycles)
    if loss.kind is LossKind.OUTPUT:
        return f"output {name}: never output any more (output today from cycle {loss.cycles[0]})"
    if loss.kind is LossKind.DRAWS:
        draws = plural(count, "recorded draw")
        return f"draws {name}: {draws} of {loss.request} no longer made ({_cycles(loss.cycles)})"
    happen = "happens" if count == 1 else "happen"
    silent = "; it never changes state in this DTC any more" if loss.silent else ""
    changes = plural(count, "state change")
    return f"{name}: {changes} no longer {happen} ({_cycles(loss.cycles)}){silent}"


def _cycles(cycles: Sequence[int]) -> str:
    """``cycle 12``, ``cycles 12, 40, 97``, ``cycles 1, 2, … 10 and 5 more``."""
    if len(cycles) == 1:
        return f"cycle {cycles[0]}"
    more = len(cycles) - _SHOWN_CYCLES
    shown = ", ".join(map(str, cycles[:_SHOWN_CYCLES]))
    return f"cycles {shown}" + (f" and {more} more" if more > 0 else "")


def closed_loop_text(weighed: Shift) -> str:
    """``closed loop for 290 of 583 cycles (50 %)``: the cycles before the behaviors
    leave the recording, of all."""
    closed, cycles = weighed.closed_loop, weighed.cycles
    share = 100 * closed // cycles if cycles else 100
    return f"closed loop for {closed} of {plural(cycles, 'cycle')} ({share} %)"


def _fields(update: PendingUpdate) -> str:
    """``4 output changes, 60 draws made otherwise, open loop since cycle 291 ...``."""
    baseline = update.baseline or Baseline(())
    count, loop = baseline.approved_states.cycles, baseline.open_loop
    rebuilt = f", robot state rebuilt otherwise in {plural(count, 'cycle')}" if count else ""
    drawn = sum(len(rule.cycles) for rule in baseline.draws)
    return (
        f"{len(baseline.outputs)} output changes"
        + rebuilt
        + (f", {plural(drawn, 'draw')} made otherwise" if drawn else "")
        + (f", {open_loop_text(loop)}" if loop else "")
        + (f", {closed_loop_text(update.shift)}" if update.shift and loop else "")
    )


def open_loop_text(open_loop: tuple[int, int]) -> str:
    """Where the behaviors left the recording: ``open loop since cycle 517 (15.510 s)``."""
    cycle, time_ns = open_loop
    return f"open loop since cycle {cycle} ({time_ns / 1e9:.3f} s)"


def render_approved(approved: Approved) -> Text:
    """The approved baseline a log is judged against, and where it goes open loop."""
    baseline = approved.baseline
    open_loop = baseline.stream.open_loop
    return Text.assemble(
        ("approved baseline", "cyan"),
        f" {baseline.path.name} (spec {approved.spec.path.name})",
        ": " + (open_loop_text(open_loop) if open_loop else "closed loop, as recorded"),
    )


def render_stale(stale: StaleSuite | None) -> list[Text]:
    """How a suite is past its open-loop limits, and the sessions to re-record first."""
    if stale is None:
        return []
    why = []
    count, over = stale.open_loop, stale.over_share
    if stale.max_dtcs is not None and count > stale.max_dtcs:
        runs = "runs" if count == 1 else "run"
        why.append(
            f"{plural(count, 'DTC')} {runs} open loop (max_open_loop_dtcs = {stale.max_dtcs})"
        )
    if over and stale.max_share is not None:
        runs, its = ("runs", "its") if over == 1 else ("run", "their")
        why.append(
            f"{over} {runs} open loop for more than {_percent(stale.max_share)} of {its} "
            f"cycles (max_open_loop_share = {stale.max_share})"
        )
    first = ", ".join(
        f"{name} ({_percent(share)}{' open loop' if not n else ''})"
        for n, (name, share) in enumerate(stale.rerecord)
    )
    return [
        Text.assemble(("stale suite", "red"), f" ([tool.beatlog]): {'; '.join(why)}"),
        Text(f"re-record first: {first}"),
    ]


def _percent(share: float) -> str:
    return f"{round(100 * share)} %"


def render_orphans(orphans: Iterable[Path]) -> list[Text]:
    """One line per expected or pending file whose spec is gone."""
    return [
        Text.assemble(("orphaned baseline", "yellow"), f" {orphan}: no spec beside it; delete it")
        for orphan in orphans
    ]


def _value(value: object) -> str:
    return json.dumps(value, default=repr)


def _run_line(run: ApprovedRun, recorded: Mapping[str, object]) -> Text:
    """``robot state "speed" rebuilt otherwise in cycles 517–4999 (4483 cycles), first:
    "speed" 0.04 → 0.041``, from the robot state ``recorded`` in its first cycle."""
    first: list[str | tuple[str, str]] = []
    for name, rebuilt in run.first.items():
        first.extend(
            [
                ", " if first else "",
                f"{json.dumps(name)} ",
                (_value(recorded.get(name)), "red"),
                " → ",
                (_value(rebuilt), "green"),
            ]
        )
    return Text.assemble(
        ("robot state ", "cyan"),
        f"{', '.join(json.dumps(name) for name in run.fields)} rebuilt otherwise in cycles "
        f"{run.cycle}–{run.last} ({plural(run.cycles, 'cycle')}), first: ",
        *first,
    )


def render_pending_diff(diff: PendingDiff, *, max_lines: int = 200) -> RenderableType:
    """The pending baseline against today's, at most ``max_lines`` lines of diff."""
    spec = diff.spec
    # open loop since cycle 291 (8.760 s): closed loop for 291 of 1164 cycles (25 %)
    loop = Text(closed_loop_text(diff.shift))
    if diff.open_loop is not None:
        loop = Text(f"{open_loop_text(diff.open_loop)}: {loop}", style="yellow")
    parts: list[RenderableType] = [
        Rule(Text(f"{spec.name} ({spec.path})")),
        Text(
            f"{diff.old_lines} state and output changes {diff.source} → {diff.new_lines} "
            f"pending: {_counts(diff.shift, '')}"
        ),
        loop,
        *render_losses(diff.shift, "lost: "),
        *(
            _run_line(run, diff.recorded.get(run.cycle, {}))
            for run in diff.rebuilt_runs[:_MAX_RUNS]
        ),
        *(
            Text.assemble(("draws ", "cyan"), str(rule))
            for rule in diff.draws
            if Loss(LossKind.DRAWS, rule.behavior, rule.cycles, request=rule.recorded)
            not in diff.shift.losses  # named as a loss
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
