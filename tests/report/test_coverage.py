"""The coverage table for people: every column stays readable on a narrow terminal."""

from __future__ import annotations

import io

from rich.console import Console

from beatlog.analysis.coverage import Seen, SuiteCoverage
from beatlog.report.coverage import render_coverage


def _text(coverage: SuiteCoverage, width: int) -> str:
    console = Console(width=width, record=True, file=io.StringIO())
    console.print(render_coverage(coverage))
    return console.export_text()


def test_a_long_unreached_column_leaves_room_for_the_states_reached() -> None:
    coverage = SuiteCoverage(dtcs=["walk"])
    wander = coverage.behavior("wander")
    wander.states = {'"roam"': Seen({"walk"}, 120), '"pause"': Seen({"walk"}, 30)}
    wander.transitions = {('"roam"', '"pause"'): Seen({"walk"}, 3)}
    wander.states_before = {f'"state{n}"': ("an-old-dtc-with-a-long-name",) for n in range(12)}

    text = _text(coverage, 80)

    assert "…" not in text  # nothing cut short: long words fold
    for shown in ('"roam"', '"pause"', "120 cycles", '"state11"', "a-long-name)"):
        assert shown in text
