"""The coverage table for people: every column stays readable on a narrow terminal."""

from __future__ import annotations

import html
import io
from pathlib import Path

from rich.console import Console

from beatlog.analysis.coverage import Seen, SuiteCoverage, cover_changes
from beatlog.analysis.recorded import read_changes
from beatlog.model.behavior import BehaviorState, PriorityArbiter, System
from beatlog.model.context import Context, Outputs
from beatlog.report.coverage import coverage_html, render_coverage
from tests.conftest import Probe
from tests.systems import record_session


def _cover(dtcs: list[tuple[str, Path, System | None]]) -> SuiteCoverage:
    """The coverage of DTCs given as (id, log, a fresh system or None)."""
    recorded = [(dtc, read_changes(log), system) for dtc, log, system in dtcs]
    return cover_changes((d, r.system, r.changes, r.cycles, s) for d, r, s in recorded)


def _text(coverage: SuiteCoverage, width: int) -> str:
    console = Console(width=width, record=True, file=io.StringIO())
    console.print(render_coverage(coverage))
    return console.export_text()


def test_a_long_unreached_column_leaves_room_for_the_states_reached() -> None:
    coverage = SuiteCoverage(dtcs=["walk"])
    wander = coverage.behavior("rover", "wander")
    wander.states = {'"roam"': Seen({"walk"}, 120), '"pause"': Seen({"walk"}, 30)}
    wander.transitions = {('"roam"', '"pause"'): Seen({"walk"}, 3)}
    wander.states_before = {f'"state{n}"': ("an-old-dtc-with-a-long-name",) for n in range(12)}

    text = _text(coverage, 80)

    assert "…" not in text  # nothing cut short: long words fold
    for shown in ('"roam"', '"pause"', "120 cycles", '"state11"', "a-long-name)"):
        assert shown in text


def test_a_behavior_of_two_systems_is_a_row_of_each_that_names_its_system() -> None:
    coverage = SuiteCoverage(dtcs=["dog/x.dtc.toml::x", "rover/x.dtc.toml::x"])
    for system in ("dog", "rover"):
        avoid = coverage.behavior(f"{system}:system", "avoid")
        avoid.states['"turning"'] = Seen({f"{system}/x.dtc.toml::x"}, 10)

    text = _text(coverage, 200)

    lines = [line.strip("│").split("│") for line in text.splitlines() if line.startswith("│")]
    assert [[cell.strip() for cell in line] for line in lines] == [
        ["dog:system", "avoid", '"turning" (1 DTC, 10 cycles)', "none", ""],
        ["rover:system", "avoid", '"turning" (1 DTC, 10 cycles)', "none", ""],
    ]
    assert coverage_html(coverage).splitlines()[0] == (
        '<section id="coverage"><h2>Transition coverage</h2><table><tr><th>system</th>'
        "<th>behavior</th><th>states reached</th><th>changes between heartbeats</th>"
        "<th>unreached</th></tr>"
    )


class Hasty:
    """Goes 2 → 3 → 1 within the heartbeat of cycle 5: the log holds 2, then 1."""

    name = "hasty"

    def __init__(self) -> None:
        self.state: BehaviorState = 2

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        if ctx.cycle == 5:
            self.state = 3
            self.state = 1
        return None


def test_a_change_within_a_heartbeat_is_labelled_as_the_states_at_successive_heartbeats(
    tmp_path: Path,
) -> None:
    log = record_session(tmp_path / "hasty.beatlog", PriorityArbiter([Hasty()], robot_state=Probe))
    coverage = _cover([("hasty", log, None)])

    text = " ".join(_text(coverage, 300).split())
    page = html.unescape(coverage_html(coverage))

    assert "│ hasty │ 2 (1 DTC, 5 cycles), 1 (1 DTC, 15 cycles) │ 2 → 1 ×1 in 1 DTC │" in text
    for shown in (text, page):
        assert "changes between heartbeats" in shown
        assert (
            "a change between heartbeats is a behavior's state at one heartbeat → its state "
            "at the next: a state passed through within one heartbeat is not logged "
            "(2 → 3 → 1 in one heartbeat shows as 2 → 1)"
        ) in shown
