"""Departures from the recording: an output line only where a field's value must change
to give the one replayed, and applying them to the recording gives it back; approved
outputs put into each recorded cycle's outputs bit for bit as applying them to the
decoded outputs gives; a baseline's departures put into the recorded cycles as replay
reads them, batch by batch, wherever in a batch they start or end."""

from __future__ import annotations

import dataclasses
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import msgspec
import pytest

from beatlog.errors import CorruptLogError
from beatlog.log.format import EMPTY_LIST, EMPTY_MAP, CycleRecord, payload_encoder
from beatlog.replay.baseline import (
    ABSENT,
    AS_RECORDED,
    Baseline,
    BaselinePart,
    TracedOutput,
    TracedStateChange,
)
from beatlog.replay.departures import (
    ApprovedOutputs,
    BaselineRecords,
    OutputDepartures,
    apply_outputs,
    hold,
)
from beatlog.replay.verdict import StateChange

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


def departure_lines() -> list[TracedOutput]:
    found = OutputDepartures()
    return [
        line
        for cycle, (recorded, replayed) in enumerate(zip(RECORDED, REPLAYED, strict=True))
        for line in found.observe(cycle, cycle * 30, recorded, replayed)
    ]


def test_a_line_only_where_a_field_departs_or_follows_the_recording_again() -> None:
    assert departure_lines() == [
        TracedOutput(1, 30, "speed", 0.0),
        TracedOutput(3, 90, "speed", AS_RECORDED),
        TracedOutput(4, 120, "turn", ABSENT),
        TracedOutput(5, 150, "turn", -0.0),
    ]


def test_the_lines_applied_to_the_recording_give_the_outputs_replayed() -> None:
    lines = departure_lines()
    held: dict[str, Any] = {}
    rebuilt = []
    for cycle, recorded in enumerate(RECORDED):
        hold(held, [line for line in lines if line.cycle == cycle])
        rebuilt.append(apply_outputs(dict(recorded), held))
    assert rebuilt == REPLAYED
    assert str(rebuilt[-1]["turn"]) == "-0.0"


LOG = Path("walk.beatlog")
ENCODE = payload_encoder().encode


def as_logged(outputs: dict[str, Any]) -> msgspec.Raw:
    return msgspec.Raw(ENCODE(outputs))


LOGGED = [
    as_logged({"happiness": 41, "motion": "walk", "speed": 0.15, "turn": 0.024}),
    as_logged({"happiness": 41, "motion": "walk", "speed": 0.15, "turn": 0.024}),
    as_logged({"happiness": -7, "motion": "walk", "speed": float("nan"), "turn": -0.0}),
    as_logged({"happiness": 300, "motion": "lie"}),
    as_logged({"speed": [0.1, 0.2], "turn": True, "motion": None}),
    msgspec.Raw(b"\x81\xa5speed\xca" + struct.pack(">f", 0.5)),  # a float32
    msgspec.Raw(b"\x82\xa5speed\x01\xa5speed\x02"),  # a field twice
    EMPTY_MAP,
]
"""Recorded outputs, one a cycle, as logged."""

HELD: list[list[tuple[str, Any]]] = [
    [],
    [("turn", 0.0)],
    [("happiness", 47), ("turn", 0.0)],
    [("turn", ABSENT)],
    [("turn", AS_RECORDED), ("speed", ABSENT), ("motion", "run")],
    [("speed", 0.0), ("wag", [1, 2]), ("sound", "woof")],  # fields the recording lacks
    [("wag", AS_RECORDED), ("happiness", AS_RECORDED), ("motion", AS_RECORDED)],
]
"""The output lines of one cycle after another."""


def records(outputs: list[msgspec.Raw]) -> list[CycleRecord]:
    return [
        CycleRecord(30 * cycle, EMPTY_MAP, EMPTY_LIST, EMPTY_LIST, raw, EMPTY_LIST)
        for cycle, raw in enumerate(outputs)
    ]


def output_lines(held: list[tuple[str, Any]]) -> list[TracedOutput]:
    return [TracedOutput(0, 0, field, value) for field, value in held]


def test_held_values_in_place_bit_for_bit_as_applying_them_gives() -> None:
    outputs = ApprovedOutputs(LOG)
    held: dict[str, Any] = {}
    got, wanted = [], []
    for changes in HELD:
        outputs.hold(output_lines(changes))
        for field, value in changes:
            if value is AS_RECORDED:
                held.pop(field, None)
            else:
                held[field] = value
        cycles = records(LOGGED)
        outputs.put(cycles[:3], 0)
        outputs.put(cycles[3:], 3)
        got.append([bytes(record.outputs) for record in cycles])
        wanted.append([ENCODE(apply_outputs(msgspec.msgpack.decode(raw), held)) for raw in LOGGED])
    assert got == wanted


def test_whether_a_field_holds_a_value() -> None:
    outputs = ApprovedOutputs(LOG)
    assert [
        outputs.hold(output_lines([("turn", 0.0)])),
        outputs.hold(output_lines([("speed", ABSENT)])),
        outputs.hold(output_lines([("turn", AS_RECORDED)])),
        outputs.hold(output_lines([("speed", AS_RECORDED)])),
    ] == [True, True, True, False]


def test_damaged_outputs_are_an_error_in_their_cycle() -> None:
    outputs = ApprovedOutputs(LOG)
    outputs.hold(output_lines([("turn", 0.0)]))
    damaged = records([LOGGED[0], LOGGED[2], msgspec.Raw(b"\x82\xa5speed\xcb\x00")])
    with pytest.raises(CorruptLogError) as raised:
        outputs.put(damaged, 10)
    assert str(raised.value) == f"{LOG}: damaged outputs in cycle 12: Input data was truncated"


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
