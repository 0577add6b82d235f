"""Baseline records: a baseline's departures put into the recorded cycles as replay
reads them, batch by batch, wherever in a batch they start or end."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import msgspec

from beatlog.log.format import EMPTY_LIST, EMPTY_MAP, CycleRecord, payload_encoder
from beatlog.replay.baseline import (
    ABSENT,
    AS_RECORDED,
    Baseline,
    BaselinePart,
    TracedOutput,
    TracedStateChange,
)
from beatlog.replay.baseline_records import BaselineRecords
from beatlog.replay.verdict import StateChange

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


BASELINE = Baseline(
    changes=(
        TracedStateChange(1, 30, StateChange("avoid", "idle", "turning")),
        TracedStateChange(4, 120, StateChange("avoid", "turning", "idle")),
        TracedStateChange(4, 120, StateChange("wander", "walk", "sit")),
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
    expected = BaselineRecords(BASELINE.stream(), NAMES, lambda name: name, None)
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


def test_the_baseline_is_read_alongside_the_log_a_part_at_a_time() -> None:
    lines = [output(cycle, "turn", float(-cycle)) for cycle in range(100)]
    pulled: list[int] = []

    def parts() -> Iterator[BaselinePart]:
        for line in lines:  # a part a cycle, the last cycle's split in two
            pulled.append(line.cycle)
            yield BaselinePart((), (), (line,), (), ())
        yield BaselinePart((), (), (output(99, "speed", 1.5),), (), ())

    stream = dataclasses.replace(Baseline((), tuple(lines)).stream(), parts=parts)
    expected = BaselineRecords(stream, NAMES, lambda name: name, None)
    batches = [[recorded(c) for c in range(start, start + 10)] for start in range(0, 100, 10)]
    read = []
    for batch in expected.batches(iter(batches), Path("walk.beatlog")):
        read.append(max(pulled))
        assert [msgspec.msgpack.decode(r.outputs)["turn"] for r in batch] == [
            -float(cycle) for cycle in range(len(read) * 10 - 10, len(read) * 10)
        ]

    assert read == [10, 20, 30, 40, 50, 60, 70, 80, 90, 99], "read ahead by one part at most"
    assert msgspec.msgpack.decode(batches[-1][-1].outputs)["speed"] == 1.5
