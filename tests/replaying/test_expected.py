"""Expected records: a baseline's departures put into the recorded cycles as replay
reads them, batch by batch, wherever in a batch they start or end."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import msgspec

from beatlog.log.format import EMPTY_LIST, EMPTY_MAP, CycleRecord, payload_encoder
from beatlog.replaying.expectation import (
    ABSENT,
    AS_RECORDED,
    Expectation,
    TracedChange,
    TracedOutput,
)
from beatlog.replaying.expected import ExpectedRecords
from beatlog.replaying.verdict import StateChange

ENCODE = payload_encoder().encode
NAMES = ["wander", "avoid"]


def recorded(cycle: int) -> CycleRecord:
    changes = [(0, "idle", "walk")] if cycle % 3 == 0 else []
    return CycleRecord(
        30 * cycle,
        EMPTY_MAP,
        msgspec.Raw(ENCODE(changes)) if changes else EMPTY_LIST,
        EMPTY_LIST,
        msgspec.Raw(ENCODE({"speed": 0.5 if cycle < 5 else 0.7, "turn": float(cycle)})),
        EMPTY_LIST,
    )


def output(cycle: int, field: str, value: Any) -> TracedOutput:
    return TracedOutput(cycle, 30 * cycle, field, value)


BASELINE = Expectation(
    changes=(
        TracedChange(1, 30, StateChange("avoid", "idle", "turning")),
        TracedChange(4, 120, StateChange("avoid", "turning", "idle")),
        TracedChange(4, 120, StateChange("wander", "walk", "sit")),
    ),
    outputs=(
        output(2, "speed", 0.0),
        output(3, "turn", ABSENT),
        output(6, "speed", AS_RECORDED),
        output(6, "wag", True),
        output(8, "turn", AS_RECORDED),
        output(8, "wag", AS_RECORDED),
    ),
    quiet=((6, 180),),
)


def test_departures_stand_in_for_the_recording_in_their_cycles_only() -> None:
    expected = ExpectedRecords(BASELINE, NAMES, lambda name: name)
    batches = [
        [recorded(cycle) for cycle in cycles] for cycles in ([0, 1, 2], [3], [4, 5, 6, 7], [8, 9])
    ]
    records = [
        record
        for batch in expected.batches(iter(batches), Path("walk.beatlog"))
        for record in batch
    ]

    assert [msgspec.msgpack.decode(record.state_changes) for record in records] == [
        [[0, "idle", "walk"]],
        [[1, "idle", "turning"]],
        [],
        [[0, "idle", "walk"]],
        [[1, "turning", "idle"], [0, "walk", "sit"]],
        [],
        [],  # quiet
        [],
        [],
        [[0, "idle", "walk"]],
    ]
    assert [msgspec.msgpack.decode(record.outputs) for record in records] == [
        {"speed": 0.5, "turn": 0.0},
        {"speed": 0.5, "turn": 1.0},
        {"speed": 0.0, "turn": 2.0},
        {"speed": 0.0},
        {"speed": 0.0},
        {"speed": 0.0},
        {"speed": 0.7, "wag": True},
        {"speed": 0.7, "wag": True},
        {"speed": 0.7, "turn": 8.0},
        {"speed": 0.7, "turn": 9.0},
    ]
