"""Departures from the recording: an output line only where a field's value must change
to give the one replayed, and applying them to the recording gives it back."""

from __future__ import annotations

from typing import Any

from beatlog.replay.baseline import ABSENT, AS_RECORDED, TracedOutput
from beatlog.replay.departures import OutputDepartures, apply_outputs, hold

RECORDED: list[dict[str, Any]] = [
    {"speed": 0.5, "turn": 0.1},
    {"speed": 0.5, "turn": 0.2},
    {"speed": 0.6, "turn": 0.3},
    {"speed": 0.7, "turn": 0.4},
    {"speed": 0.7, "turn": 0.5},
    {"speed": 0.7},
]
REPLAYED: list[dict[str, Any]] = [
    {"speed": 0.5, "turn": 0.1},  # as recorded
    {"speed": 0.0, "turn": 0.2},  # speed departs
    {"speed": 0.0, "turn": 0.3},  # and holds, whatever was recorded
    {"speed": 0.7, "turn": 0.4},  # speed follows the recording again
    {"speed": 0.7},  # turn is no longer output
    {"speed": 0.7, "turn": -0.0},  # a field the recording lacks, bit for bit
]


def departures() -> list[TracedOutput]:
    found = OutputDepartures()
    return [
        line
        for cycle, (recorded, replayed) in enumerate(zip(RECORDED, REPLAYED, strict=True))
        for line in found.observe(cycle, cycle * 30, recorded, replayed)
    ]


def test_a_line_only_where_a_field_departs_or_follows_the_recording_again() -> None:
    assert departures() == [
        TracedOutput(1, 30, "speed", 0.0),
        TracedOutput(3, 90, "speed", AS_RECORDED),
        TracedOutput(4, 120, "turn", ABSENT),
        TracedOutput(5, 150, "turn", -0.0),
    ]


def test_the_lines_applied_to_the_recording_give_the_outputs_replayed() -> None:
    lines = departures()
    held: dict[str, Any] = {}
    rebuilt = []
    for cycle, recorded in enumerate(RECORDED):
        hold(held, [line for line in lines if line.cycle == cycle])
        rebuilt.append(apply_outputs(dict(recorded), held))
    assert rebuilt == REPLAYED
    assert str(rebuilt[-1]["turn"]) == "-0.0"
