"""The coverage table for people: every column stays readable on a narrow terminal."""

from __future__ import annotations

import io

from rich.console import Console

from beatlog.analysis.coverage import Seen, SuiteCoverage
from beatlog.report.coverage import coverage_html, render_coverage


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
        "<th>behavior</th><th>states reached</th><th>transitions</th><th>unreached</th></tr>"
    )
