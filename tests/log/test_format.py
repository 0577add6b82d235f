"""The session log format: every value a robot records comes back bit for bit."""

from __future__ import annotations

import math
import struct
import sys
from pathlib import Path
from typing import Any

import msgspec
import pytest

from beatlog.log.format import (
    CYCLES_TOPIC,
    EMPTY_LIST,
    EMPTY_MAP,
    END_TOPIC,
    FORMAT_VERSION,
    HEADER_TOPIC,
    CycleRecord,
    Draw,
    SessionHeader,
)
from beatlog.log.reader import SessionLogReader
from beatlog.log.writer import SessionLogWriter
from beatlog.model.state import RobotState
from beatlog.record.recorder import Recorder
from tests.conftest import PERIOD_NS, Probe, RecordFn, probe_system
from tests.crafting import session_header


def float_from_bits(bits: int) -> float:
    value: float = struct.unpack("<d", struct.pack("<Q", bits))[0]
    return value


def bits(value: float) -> int:
    pattern: int = struct.unpack("<Q", struct.pack("<d", value))[0]
    return pattern


SPECIAL_FLOATS = [
    pytest.param(float_from_bits(0x7FF8000000000123), id="nan-with-payload"),
    pytest.param(float_from_bits(0xFFF8000000000000), id="negative-nan"),
    pytest.param(math.inf, id="+inf"),
    pytest.param(-math.inf, id="-inf"),
    pytest.param(-0.0, id="-0.0"),
    pytest.param(5e-324, id="smallest-subnormal"),
    pytest.param(sys.float_info.max, id="largest-float"),
    pytest.param(0.1, id="0.1"),
]

INTS = [2**64 - 1, 2**63, -(2**63), 2**32 + 1, -1, 0]
STRINGS = ["", "ünïcödé", "日本語のロボット", "robot 🤖", "tab\tnewline\nnul\x00", "z" * 70_000]


class Gauge(RobotState, kw_only=True):
    """A robot state with an int and a string, for values a Probe cannot hold."""

    count: int = 0
    label: str = ""


def write_log(path: Path, states: list[msgspec.Struct], outputs: list[dict[str, Any]]) -> Path:
    """Write one cycle per state with the matching outputs; returns the path."""
    with SessionLogWriter(path, session_header()) as writer:
        for state, out in zip(states, outputs, strict=True):
            writer.append(PERIOD_NS, state, [], [], out)
    return path


def read_cycles(path: Path) -> list[CycleRecord]:
    with SessionLogReader(path) as reader:
        return list(reader.cycles())


@pytest.mark.parametrize("value", SPECIAL_FLOATS)
def test_a_special_float_in_the_robot_state_round_trips_bit_for_bit(
    tmp_path: Path, value: float
) -> None:
    log = tmp_path / "special.beatlog"
    with Recorder(log, probe_system(), seed=1, software="test") as recorder:
        recorder.step(PERIOD_NS, Probe(distance=1.0, reading=value))

    [cycle] = read_cycles(log)
    state = msgspec.msgpack.decode(cycle.robot_state, type=Probe)

    assert bits(state.reading) == bits(value)
    assert math.copysign(1.0, state.reading) == math.copysign(1.0, value)


@pytest.mark.parametrize("value", SPECIAL_FLOATS)
def test_a_special_float_in_the_outputs_round_trips_bit_for_bit(
    tmp_path: Path, value: float
) -> None:
    log = write_log(tmp_path / "special.beatlog", [Gauge()], [{"reading": value}])

    [cycle] = read_cycles(log)
    outputs = msgspec.msgpack.decode(cycle.outputs, type=dict[str, float])

    assert bits(outputs["reading"]) == bits(value)
    assert math.copysign(1.0, outputs["reading"]) == math.copysign(1.0, value)


def test_big_and_small_ints_round_trip_exactly_in_state_and_outputs(tmp_path: Path) -> None:
    states: list[msgspec.Struct] = [Gauge(count=n) for n in INTS]
    log = write_log(tmp_path / "ints.beatlog", states, [{"count": n} for n in INTS])

    cycles = read_cycles(log)

    assert [msgspec.msgpack.decode(c.robot_state, type=Gauge).count for c in cycles] == INTS
    assert [msgspec.msgpack.decode(c.outputs)["count"] for c in cycles] == INTS


def test_unicode_strings_round_trip_exactly_in_state_and_outputs(tmp_path: Path) -> None:
    states: list[msgspec.Struct] = [Gauge(label=s) for s in STRINGS]
    log = write_log(tmp_path / "strings.beatlog", states, [{s: s} for s in STRINGS])

    cycles = read_cycles(log)

    assert [msgspec.msgpack.decode(c.robot_state, type=Gauge).label for c in cycles] == STRINGS
    assert [msgspec.msgpack.decode(c.outputs) for c in cycles] == [{s: s} for s in STRINGS]


def test_the_header_round_trips_with_the_catalogue_and_robot_state_schema(
    record_probe: RecordFn,
) -> None:
    log = record_probe(20, robot_id="rover-7 🤖", period_ns=20_000_000, flush_interval_s=0.25)

    with SessionLogReader(log) as reader:
        header = reader.header

    assert header.format_version == FORMAT_VERSION
    assert header.robot_id == "rover-7 🤖"
    assert header.period_ns == 20_000_000
    assert header.flush_interval_ns == 250_000_000
    assert header.system == "tests.conftest:probe_system"
    assert header.software_version == "test"
    assert header.random_seed == 7
    assert header.behaviors == list(probe_system().behaviors) == ["arbiter", "near", "dice"]
    assert header.robot_state_type == "tests.conftest.Probe"
    probe_schema = header.robot_state_schema["$defs"]["Probe"]
    assert set(probe_schema["properties"]) == {"distance", "reading"}


def test_a_cycle_record_is_a_msgpack_array_of_its_six_parts() -> None:
    record = CycleRecord(
        heartbeat_ns=PERIOD_NS,
        robot_state=msgspec.Raw(msgspec.msgpack.encode({"distance": 1.0})),
        state_changes=EMPTY_LIST,
        random_numbers=EMPTY_LIST,
        outputs=EMPTY_MAP,
        samples=EMPTY_LIST,
    )

    encoded = msgspec.msgpack.encode(record)

    assert msgspec.msgpack.decode(encoded) == [PERIOD_NS, {"distance": 1.0}, [], [], {}, []]
    assert msgspec.msgpack.decode(encoded, type=CycleRecord) == record


def test_the_empty_markers_are_the_msgpack_encodings_of_empty_containers() -> None:
    assert bytes(EMPTY_LIST) == msgspec.msgpack.encode([])
    assert bytes(EMPTY_MAP) == msgspec.msgpack.encode({})


def test_a_header_without_the_optional_fields_reads_with_their_defaults() -> None:
    minimal = msgspec.to_builtins(session_header())
    for optional in ("random_seed", "samples_logged", "flush_interval_ns"):
        del minimal[optional]

    header = msgspec.msgpack.decode(msgspec.msgpack.encode(minimal), type=SessionHeader)

    assert header.random_seed is None
    assert header.samples_logged is False
    assert header.flush_interval_ns == 1_000_000_000


def test_a_header_with_a_field_added_later_in_the_same_version_still_reads() -> None:
    newer = {**msgspec.to_builtins(session_header()), "calibration": {"wheel": 0.1}}

    header = msgspec.msgpack.decode(msgspec.msgpack.encode(newer), type=SessionHeader)

    assert header.robot_id == "bench"


def test_the_three_channels_have_distinct_beatlog_topics() -> None:
    topics = (HEADER_TOPIC, CYCLES_TOPIC, END_TOPIC)
    assert len(set(topics)) == 3
    assert all(topic.startswith("/beatlog/") for topic in topics)


@pytest.mark.parametrize(
    ("params", "text"),
    [
        ((0.8, 1.6), "uniform(0.8, 1.6)"),
        ((2, 5), "uniform(2, 5)"),
        ((2.0, 5), "uniform(2.0, 5)"),
        ((-0.0, 1.0), "uniform(-0.0, 1.0)"),
        ((0.0, 1.0), "uniform(0.0, 1.0)"),
        ((True, 2), "uniform(True, 2)"),
        ((float("nan"), float("-inf")), "uniform(nan, -inf)"),
        ((10**30, 1.5), "uniform(1000000000000000000000000000000, 1.5)"),
        ((0.0, 1.0, [3, 2]), "uniform(0.0, 1.0, [3, 2])"),
        ((), "uniform()"),
    ],
)
def test_a_draw_writes_its_request_exactly_as_code_every_time(
    params: tuple[Any, ...], text: str
) -> None:
    Draw(0, "uniform", 0.5, (0.0, 1.0)).call()  # equal as numbers to some above, written first
    draws = [Draw(0, "uniform", 0.5, params), Draw(1, "uniform", 0.7, params)]

    assert [draw.call() for draw in draws] == [text, text]
