"""Turns results into rich renderables for the terminal, pytest and JUnit; it decides nothing."""

from __future__ import annotations

import datetime as dt
import io
import json
from collections import Counter
from collections.abc import Sequence
from itertools import zip_longest
from typing import Any

from rich.console import Console, Group, RenderableType
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from beatlog.analysis.summary import LogSummary
from beatlog.log.format import COLUMNS_SINCE
from beatlog.replay.verdict import Divergence, DivergenceKind, ReplayResult
from beatlog.report.counts import plural
from beatlog.suite.runner import SpecOutcome, Verdict

__all__ = [
    "LEGEND",
    "MAX_LISTED",
    "SUMMARY_COLUMNS",
    "plain_text",
    "render_outcome",
    "render_passed",
    "render_replay",
    "render_suite",
    "render_summary",
]

MAX_LISTED = 30
"""The most DTCs a suite's summary table lists whole: about a screenful."""

SUMMARY_COLUMNS = ("DTC", "verdict", "cycles", "robot time", "wall", "first divergence")
"""The columns of a suite's summary table."""

LEGEND = "beatlog help WORD explains a word above, e.g. beatlog help open-loop"
"""The line under a suite's summary table: where its words are explained, offline."""

_OLDER_FORMAT = " (older: replays with the integrity checks it supports)"
MEASURABLE_S = 0.001
"""The shortest wall time a replay's figures report, and compute a speed-up from."""


def _timed(result: ReplayResult) -> str:
    """How long a replay took, and how many times real time that is: to two figures
    when slower than ten times (a short replay, where opening the log is most of the
    time, is not "0×"); no speed for a replay too short to time or of no robot time."""
    if result.wall_time_s < MEASURABLE_S:
        return "in under 1 ms"  # too short to time: a speed-up would be noise
    took = f"in {result.wall_time_s:.3f} s"
    if result.robot_time_ns <= 0:
        return took
    speedup = result.speedup
    return f"{took} ({format(speedup, ',.0f' if speedup >= 10 else '.2g')}× real time)"


def _checked_text(result: ReplayResult) -> str:
    """What a replay checked, the counts that are not 0: ``167 cycles, 12 state changes,
    40 outputs, 9 draws checked``; a pass allowed to check nothing says so."""
    checked = result.checked
    counts = [
        plural(count, noun)
        for count, noun in (
            (result.cycles, "cycle"),
            (checked.state_changes, "state change"),
            (checked.outputs, "output"),
            (checked.draws, "draw"),
            (checked.samples, "sample"),
        )
        if count or noun == "cycle"
    ]
    return ", ".join(counts) + " checked" + ("" if checked.anything else " (allowed empty)")


def render_passed(outcome: SpecOutcome) -> Text:
    """A passing DTC's line with what it checked, for a run that lists every DTC, and,
    for a log behind a URL, how long it waited for its copy."""
    assert outcome.result is not None
    waited = outcome.storage_wait_s
    storage = "" if waited is None else f"; {waited:.2f} s waiting for storage"
    return Text.assemble(
        ("PASS ", "bold green"),
        f"{outcome.spec.label}: {_checked_text(outcome.result)}{storage}",
    )


def render_outcome(outcome: SpecOutcome) -> RenderableType:
    """A DTC's outcome: one line for an error or a pass (what it checked), the first
    divergence for a failure."""
    if outcome.verdict is Verdict.PASSED:
        return render_passed(outcome)
    if outcome.result is None:
        return Text.assemble(("ERROR ", "bold magenta"), f"{outcome.spec.label}: {outcome.error}")
    return Group(
        Text.assemble(("DTC ", "bold"), f"{outcome.spec.label} ({outcome.spec.origin})"),
        render_replay(outcome.result),
    )


def render_replay(result: ReplayResult) -> RenderableType:
    """A pass line with what it checked, or the first divergence in one screen."""
    timing = f"{result.robot_time_s:.1f} s robot time {_timed(result)}"
    status = "" if result.status is None else f"; log {result.status.describe()}"
    notes = [Text.assemble(("note: ", "yellow"), note) for note in result.notes]
    if result.ok:
        verdict = Text.assemble(
            ("PASS ", "bold green"),
            f"{result.log_name}  {_checked_text(result)}; {timing}{status}",
        )
        return Group(verdict, *notes) if notes else verdict
    divergence = result.divergence
    assert divergence is not None
    figures = f"{plural(result.cycles, 'cycle')}, {timing}"
    parts: list[RenderableType] = [
        Text.assemble(("FAIL ", "bold red"), f"{result.log_name}  {figures}{status}"),
        *notes,
        _divergence(divergence),
    ]
    if result.divergent_cycles > 1:
        parts.append(Text(f"{result.divergent_cycles} cycles diverged in all.", style="yellow"))
    parts.append(Text.assemble(("reproduce: ", "dim"), result.reproduce))
    return Group(*parts)


def _divergence(divergence: Divergence) -> RenderableType:
    title = (
        f"first divergence: at set-up, before cycle 0, {divergence.kind.value}"
        if divergence.kind is DivergenceKind.SETUP
        else f"first divergence: cycle {divergence.cycle}, t = {divergence.time_s:.3f} s, "
        f"{divergence.kind.value}"
    )
    # Wrapped inside the panel even on a soft-wrapping console, which would clip it.
    parts: list[RenderableType] = [
        Text(divergence.message, style="bold", no_wrap=False, overflow="fold")
    ]
    if divergence.proposed_renames:
        parts.append(_rename_proposal(divergence.proposed_renames))
    if divergence.perception:
        parts.append(_side_by_side("robot state from the samples", *divergence.perception_sides))
    if divergence.samples:
        parts.append(Text.assemble(("samples: ", "dim"), divergence.samples_text))
    if divergence.expected or divergence.actual:
        parts.append(
            _side_by_side("behavior state changes", divergence.expected, divergence.actual)
        )
    # Outputs are judged bit for bit: 0.0 and -0.0 differ though they compare equal.
    if divergence.kind is DivergenceKind.OUTPUTS or (
        divergence.kind is DivergenceKind.STATE_CHANGES
        and divergence.expected_outputs != divergence.actual_outputs
    ):
        parts.append(_side_by_side("outputs", *divergence.output_sides))
    if divergence.random_recorded or divergence.random_drawn:
        parts.append(
            _side_by_side("random numbers", divergence.random_recorded, divergence.random_drawn)
        )
    if divergence.kind is DivergenceKind.INVARIANT:
        parts.append(_values("behavior states after the update", divergence.states))
        parts.append(_values("outputs", divergence.actual_outputs))
    if len(divergence.context) > 1:
        parts.append(_context(divergence))
    if divergence.robot_state:
        parts.append(_robot_state(divergence.robot_state, divergence.fields_read))
    if divergence.traceback:
        parts.append(Text(divergence.traceback.rstrip(), style="red"))
    return Panel(Group(*parts), title=title, title_align="left", border_style="red")


def _rename_proposal(renames: dict[str, str]) -> Text:
    pairs = ", ".join(f"{old} → {new}" for old, new in renames.items())
    table = ", ".join(f"{json.dumps(old)} = {json.dumps(new)}" for old, new in renames.items())
    return Text.assemble(
        ("The whole trace differs only by renamed behaviors: ", "yellow"),
        pairs,
        ("\nIf intended, add to the spec: ", "yellow"),
        f"renames = {{ {table} }}",
    )


def _side_by_side(what: str, expected: Sequence[Any], actual: Sequence[Any]) -> Table:
    table = Table(title=what, title_justify="left", expand=True)
    table.add_column("recorded", style="green", ratio=1)
    table.add_column("replayed", style="red", ratio=1)
    rows = zip_longest(map(str, expected), map(str, actual), fillvalue="—")
    for want, got in [*rows] or [("—", "—")]:
        table.add_row(Text(want), Text(got), style=None if want == got else "bold")
    return table


def _context(divergence: Divergence) -> Table:
    table = Table(title="state changes around it", title_justify="left", expand=True)
    table.add_column("cycle", justify="right")
    table.add_column("t (s)", justify="right")
    table.add_column("recorded", style="green", ratio=1)
    table.add_column("replayed", style="red", ratio=1)
    for row in divergence.context:
        here = row.cycle == divergence.cycle
        table.add_row(
            f"▶ {row.cycle}" if here else str(row.cycle),
            f"{row.time_ns / 1e9:.3f}",
            Text("\n".join(map(str, row.expected)) or "—"),
            Text("\n".join(map(str, row.actual)) or "—"),
            style="bold" if here or row.expected != row.actual else "dim",
        )
    return table


def _values(title: str, values: dict[str, Any]) -> Table:
    """Named values, one a row: what an invariant saw, a robot state."""
    table = Table(title=title, title_justify="left", show_header=False, expand=True)
    table.add_column("name", style="cyan")
    table.add_column("value")
    for name, value in values.items():
        table.add_row(name, Text(repr(value)))
    if not values:
        table.add_row("—", "")
    return table


def _robot_state(state: dict[str, Any], read: Sequence[str]) -> Table:
    """RS_t: the fields the behaviors read in the cycle when known, else all of them."""
    shown = [name for name in read if name in state] or list(state)
    title = "robot state RS_t" + (", fields read in this cycle" if read else "")
    table = _values(title, {name: state[name] for name in shown})
    if len(shown) < len(state):
        hidden = len(state) - len(shown)
        more = f"{plural(hidden, 'more field')} not read"
        table.add_row("", Text(more, style="dim"))
    return table


def render_summary(summary: LogSummary) -> RenderableType:
    """The header and figures of a log, for ``beatlog show``."""
    header = summary.header
    about = Table(show_header=False, box=None)
    about.add_column(style="cyan")
    about.add_column()
    started = dt.datetime.fromtimestamp(header.start_time_ns / 1e9, tz=dt.UTC)
    overruns = "unknown (no end record)" if summary.end is None else str(summary.end.overruns)
    rows = [
        ("log", summary.log_name),
        (
            "format",
            f"version {summary.format_version}"
            # every integrity check of the current format, else those it supports
            + ("" if summary.format_version >= COLUMNS_SINCE else _OLDER_FORMAT),
        ),
        ("status", summary.status.describe()),
        ("robot", header.robot_id),
        ("software", header.software_version),
        ("system", header.system or "(not recorded)"),
        (
            "recorded",
            f"{started:%Y-%m-%d %H:%M:%S} UTC with beatlog {header.beatlog_version}"
            + ("" if (python := header.recorded_python()) is None else f" under Python {python}"),
        ),
        ("duration", f"{summary.robot_time_ns / 1e9:.3f} s robot time"),
        ("cycles", str(summary.cycles)),
        (
            "heartbeat",
            f"period {header.period_ns / 1e6:g} ms; mean {summary.heartbeat_mean_ms:.3f} ms, "
            f"p99 {summary.heartbeat_p99_ms:.3f} ms, max {summary.heartbeat_max_ms:.3f} ms",
        ),
        ("overruns", f"{overruns}; {summary.late_beats} beats later than 1.5 periods"),
        ("robot state", header.robot_state_type),
        ("random numbers", _counts(summary.random_draws) or "none"),
        *(
            [("set-up draws", _counts(Counter(draw.kind for draw in setup_draws)))]
            if (setup_draws := header.drawn_at_setup())
            else []
        ),
        (
            "samples",
            "not logged" if summary.samples is None else _counts(summary.samples) or "none",
        ),
    ]
    if summary.end is not None and summary.end.error:
        rows.append(("recording error", summary.end.error))
    for name, value in rows:
        about.add_row(name, Text(value))
    behaviors = Table(title="behaviors", title_justify="left")
    behaviors.add_column("id")
    behaviors.add_column("behavior")
    behaviors.add_column("state changes", justify="right")
    for index, (name, count) in enumerate(summary.transitions.items()):
        behaviors.add_row(str(index), Text(name), str(count))
    return Group(about, behaviors)


def _counts(counts: dict[str, int]) -> str:
    total = sum(counts.values())
    if not total:
        return ""
    return f"{total} ({', '.join(f'{kind} {n}' for kind, n in counts.items())})"


def render_suite(outcomes: Sequence[SpecOutcome], *, every: bool = False) -> RenderableType:
    """The summary table of a suite run, one row per DTC; with more than
    :data:`MAX_LISTED` DTCs, unless ``every``, only those that did not pass, and a line
    that counts the others. A variant that passed is never listed unless ``every``: a
    line counts them."""
    listed = outcomes
    if not every:
        many = len(outcomes) > MAX_LISTED
        listed = [
            outcome
            for outcome in outcomes
            if outcome.verdict is not Verdict.PASSED
            or not (many or outcome.spec.variant is not None)
        ]
    table = Table(title="DTC suite", title_justify="left", caption=LEGEND, caption_justify="left")
    table.add_column("DTC", overflow="fold")  # an id folds, never cut to its shared start
    for column in SUMMARY_COLUMNS[1:]:
        table.add_column(column, justify="right" if column in ("cycles", "wall") else "left")
    styles = {Verdict.PASSED: "green", Verdict.FAILED: "red", Verdict.ERROR: "magenta"}
    for outcome in listed:
        result = outcome.result
        divergence = result.divergence if result else None
        table.add_row(
            Text(outcome.spec.label),
            Text(outcome.verdict_label, style=styles[outcome.verdict]),
            str(result.cycles) if result else "—",
            f"{result.robot_time_s:.1f} s" if result else "—",
            f"{outcome.wall_time_s:.2f} s",
            Text(
                f"cycle {divergence.cycle}, {divergence.kind.value}"
                if divergence
                else (outcome.error or "")
            ),
        )
    if len(listed) == len(outcomes):
        return table
    hidden = len(outcomes) - len(listed)
    variants = sum(
        outcome.spec.variant is not None and outcome.verdict is Verdict.PASSED
        for outcome in outcomes
    )
    among = f" ({variants} of them variants)" if variants else ""
    rest = Text(
        f"{'… and ' if listed else ''}{hidden} passed{among}, not listed: "
        "run with --verbose to list every DTC",
        style="dim",
    )
    return Group(table, rest) if listed else rest  # no table of nothing


def plain_text(renderable: RenderableType, *, width: int = 100) -> str:
    """A renderable as plain text, for JUnit reports and pytest failure messages."""
    text = io.StringIO()
    console = Console(
        file=text, width=width, color_system=None, force_terminal=False, soft_wrap=True
    )
    console.print(renderable)
    return text.getvalue()
