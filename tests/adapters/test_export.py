"""``beatlog export``: a session opened in Foxglove or Lichtblick, or read as a table.

Every exported MCAP is read back: every channel's schema must be one the viewers'
schema parser accepts (``tests/viewer_schema.py``, ported from it), and every message
strict JSON that validates against its channel's schema with a standard validator.
"""

from __future__ import annotations

import base64
import csv
import functools
import json
import math
import platform
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal, NamedTuple

import duckdb
import msgspec
import pyarrow.dataset as ds
import pyarrow.parquet as pq
import pytest
from jsonschema.exceptions import ValidationError
from jsonschema.validators import validator_for
from mcap.reader import make_reader

from beatlog.adapters.export import ExportFormat, export
from beatlog.adapters.rosbag import import_bag
from beatlog.analysis.summary import summarize
from beatlog.errors import ExportError
from beatlog.log.format import CYCLES_TOPIC, FORMAT_VERSION
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.model.behavior import BehaviorState, PriorityArbiter
from beatlog.model.context import Context, Outputs
from beatlog.model.inbox import Sample
from beatlog.model.state import RobotState
from beatlog.record.recorder import Recorder
from beatlog_examples.rover import record_lockstep
from tests.bags import (
    LOGS_FROM_NS,
    SONAR_EVERY_NS,
    START_NS,
    TICK_EVERY_NS,
    perception,
    write_bag,
)
from tests.commands import Beatlog, assert_error, assert_error_matching, cannot_import
from tests.conftest import PERIOD_NS, Dice, Near, Probe, RecordFn, distances, probe_system
from tests.crafting import Message as LogMessage
from tests.crafting import (
    craft_log,
    cycle,
    cycle_messages,
    deeply_nested,
    end_message,
    header_message,
)
from tests.marks import one_by_default
from tests.perceptions import record_with_samples
from tests.systems import record_scatter
from tests.viewer_schema import ViewerSchemaError, check_viewer_schema

COMMITTED = sorted((Path(__file__).parents[2] / "examples/src").glob("**/suite/*.beatlog"))
"""Every DTC log the examples commit: the dog's suite and the py_trees patrol's."""
SMALL_COMMITTED = COMMITTED[0].parents[2] / "trees/suite/low-battery.beatlog"
"""The smallest of them, exported in the default run (the others under ``-m slow``)."""


def committed_id(log: Path) -> str:
    """A committed log's test id: its example and its name."""
    return f"{log.parts[-3]}/{log.stem}"


PER_CYCLE_TOPICS = ("/robot_state", "/heartbeat", "/outputs")
PROBE_TOPICS = [
    *("/behaviors/arbiter", "/behaviors/dice", "/behaviors/near"),
    *("/heartbeat", "/outputs", "/random_numbers", "/robot_state", "/state_changes"),
]
"""The topics of a probe log exported without a divergence, sorted."""


class Exported(NamedTuple):
    """An exported MCAP read back: each topic's schema and its messages in log-time order."""

    schemas: dict[str, dict[str, Any]]
    schema_names: dict[str, str]
    messages: dict[str, list[Read]]


class Read(NamedTuple):
    """One message read back: its log time, sequence number and JSON value."""

    log_time: int
    sequence: int
    value: Any


def _no_constant(name: str) -> Any:
    raise AssertionError(f"{name} is not JSON")


SHAPE_KEYWORDS = frozenset(
    {"$schema", "title", "description", "type", "properties", "required"}
    | {"additionalProperties", "items", "minimum", "maximum"}
)
"""The keywords of the export's schemas under which a message's validity depends only on
its shape (:func:`shape`): the JSON types, the keys, and each number's side of every
bound in the schema."""


def keywords(schema: dict[str, Any]) -> set[str]:
    """Every keyword a schema uses, at any depth."""
    found = set(schema)
    for key, value in schema.items():
        if key == "properties":
            found.update(*map(keywords, value.values()))
        elif isinstance(value, dict):
            found.update(keywords(value))
        elif isinstance(value, list):
            found.update(*(keywords(item) for item in value if isinstance(item, dict)))
    return found


def bounds(document: Any) -> tuple[float, ...]:
    """Every minimum and maximum of a schema, sorted."""
    found: set[float] = set()
    if isinstance(document, dict):
        found.update(document[key] for key in ("minimum", "maximum") if key in document)
        found.update(*map(bounds, document.values()))
    elif isinstance(document, list):
        found.update(*map(bounds, document))
    return tuple(sorted(found))


def shape(value: Any, limits: tuple[float, ...]) -> Any:
    """What validation under :data:`SHAPE_KEYWORDS` sees of a JSON value: two values of
    the same shape are valid or invalid together."""
    if isinstance(value, dict):
        return tuple(sorted((key, shape(item, limits)) for key, item in value.items()))
    if isinstance(value, list):
        return ("[", *(shape(item, limits) for item in value))
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return type(value).__name__
    if isinstance(value, int | float):
        integral = isinstance(value, int) or value.is_integer()
        return (integral, *((value < limit, value > limit) for limit in limits))
    raise AssertionError(f"{value!r} is not JSON")


class Validator:
    """A standard validator of one schema that validates each shape of message once,
    where the schema's keywords allow it (:data:`SHAPE_KEYWORDS`), every message else."""

    def __init__(self, document: dict[str, Any]) -> None:
        standard = validator_for(document)
        standard.check_schema(document)
        self._standard = standard(document)
        self._by_shape = keywords(document) <= SHAPE_KEYWORDS
        self._limits = bounds(document)
        self._valid: set[Any] = set()

    def validate(self, value: Any) -> None:
        if not self._by_shape:
            self._standard.validate(value)
            return
        key = shape(value, self._limits)
        if key not in self._valid:
            self._standard.validate(value)
            self._valid.add(key)


@functools.cache
def validator(data: bytes) -> Validator:
    """The validator of a schema's text, made once across the tests."""
    return Validator(json.loads(data, parse_constant=_no_constant))


def read_exported(path: Path) -> Exported:
    """Read an export, checking that the viewers parse every channel's schema and that each
    message is strict JSON valid under its channel's schema."""
    with path.open("rb") as file:
        reader = make_reader(file)
        summary = reader.get_summary()
        assert summary is not None
        validators = {}
        schemas: dict[str, dict[str, Any]] = {}
        names: dict[str, str] = {}
        for channel in summary.channels.values():
            schema = summary.schemas[channel.schema_id]
            assert (channel.message_encoding, schema.encoding) == ("json", "jsonschema")
            document = json.loads(schema.data, parse_constant=_no_constant)
            check_viewer_schema(document)
            validators[channel.id] = validator(schema.data)
            schemas[channel.topic] = document
            names[channel.topic] = schema.name
        messages: dict[str, list[Read]] = {topic: [] for topic in schemas}
        for _, channel, message in reader.iter_messages(log_time_order=False):
            value = json.loads(message.data, parse_constant=_no_constant)
            validators[channel.id].validate(value)
            assert message.publish_time == message.log_time
            messages[channel.topic].append(Read(message.log_time, message.sequence, value))
    for read in messages.values():
        read.sort(key=lambda message: message.log_time)  # stable: ties keep the file's order
    return Exported(schemas, names, messages)


def mcap_metadata(path: Path) -> dict[str, dict[str, str]]:
    """The metadata records of an MCAP file, by name."""
    with path.open("rb") as file:
        return {record.name: record.metadata for record in make_reader(file).iter_metadata()}


LOG_TIME = (
    "each message is stamped with the recording's start (start_time_ns, Unix ns) plus "
    "the robot time at the end of its cycle"
)


def robot_times(log: Path) -> list[int]:
    """Each cycle's robot time (ns), read from the log."""
    times, now = [], 0
    with SessionLogReader(log) as reader:
        for record in reader.cycles():
            now += record.heartbeat_ns
            times.append(now)
    return times


def log_times(log: Path) -> list[int]:
    """Each cycle's log time in an MCAP export: the recording's start plus its robot time."""
    with SessionLogReader(log) as reader:
        start_ns = reader.header.start_time_ns
    return [start_ns + time for time in robot_times(log)]


@pytest.fixture
def probe_log(record_probe: RecordFn) -> Path:
    return record_probe(300)


# a robot with a nested robot state that draws numpy arrays


class Pose(msgspec.Struct):
    x: float = 0.0
    heading: float = 0.0


class Tracked(RobotState, kw_only=True):
    pose: Pose = msgspec.field(default_factory=Pose)
    ranges: list[float] = msgspec.field(default_factory=list)


class Scan:
    """Draws a noise array every cycle and outputs it; 'busy' while the robot is far out."""

    name = "scan"

    def __init__(self) -> None:
        self.state: BehaviorState = "idle"

    def step(self, rs: Tracked, ctx: Context) -> Outputs | None:
        self.state = "busy" if rs.pose.x > 1.0 else "idle"
        return {"noise": ctx.random.uniform_array(0.0, 1.0, 3)}


@pytest.fixture
def tracked_log(tmp_path: Path) -> Path:
    path = tmp_path / "tracked.beatlog"
    with Recorder(path, PriorityArbiter([Scan()], robot_state=Tracked), seed=3) as recorder:
        for t in range(40):
            recorder.step(PERIOD_NS, Tracked(pose=Pose(x=t / 10), ranges=[0.5, float(t)]))
    return path


# MCAP for the viewers


@pytest.mark.parametrize("source", ["probe", "rover", "tracked"])
def test_every_exported_message_validates_against_its_channel_schema(
    source: str, record_probe: RecordFn, tracked_log: Path, tmp_path: Path
) -> None:
    if source == "probe":
        log = record_probe(300)
    elif source == "rover":
        log = tmp_path / "rover.beatlog"
        record_lockstep(log, duration_s=20.0, seed=2)
    else:
        log = tracked_log
    exported = tmp_path / "out.mcap"

    result = export(log, exported)

    read = read_exported(exported)  # validates every message
    cycles = summarize(log).cycles
    assert result.cycles == cycles
    assert all(len(read.messages[topic]) == cycles for topic in PER_CYCLE_TOPICS)


def test_the_channels_and_their_counts_follow_the_log(probe_log: Path, tmp_path: Path) -> None:
    exported = tmp_path / "probe.mcap"
    export(probe_log, exported)

    read = read_exported(exported)

    summary = summarize(probe_log)
    assert list(read.messages) == [
        "/robot_state",
        "/behaviors/arbiter",
        "/behaviors/near",
        "/behaviors/dice",
        "/state_changes",
        "/outputs",
        "/random_numbers",
        "/heartbeat",
    ]
    assert read.schema_names["/state_changes"] == "foxglove.Log"
    assert read.schema_names["/robot_state"] == summary.header.robot_state_type
    times = log_times(probe_log)
    for topic in PER_CYCLE_TOPICS:
        assert [(m.log_time, m.sequence) for m in read.messages[topic]] == [
            (time, cycle) for cycle, time in enumerate(times)
        ]
    assert len(read.messages["/state_changes"]) == sum(summary.transitions.values())
    assert len(read.messages["/random_numbers"]) == 60  # dice draws every 5 cycles
    assert read.messages["/robot_state"][10].value == {"distance": distances(300)[10], "reading": 0}
    assert read.messages["/heartbeat"][1].value == {
        "cycle": 1,
        "interval_ns": PERIOD_NS + 1000,
        "interval_ms": (PERIOD_NS + 1000) / 1e6,
    }
    assert read.messages["/outputs"][0].value["outputs"]["speed"] == 0.5


def test_behavior_channels_hold_the_state_at_cycle_0_and_after_every_change(
    probe_log: Path, tmp_path: Path
) -> None:
    exported = tmp_path / "probe.mcap"
    export(probe_log, exported)

    near = read_exported(exported).messages["/behaviors/near"]

    first_near = next(t for t, d in enumerate(distances(300)) if d < 0.5)
    times = log_times(probe_log)
    assert near[0] == Read(times[0], 0, {"cycle": 0, "state": "far"})
    assert near[1] == Read(times[first_near], first_near, {"cycle": first_near, "state": "near"})
    assert len(near) == 1 + summarize(probe_log).transitions["near"]


def test_each_state_change_is_a_foxglove_log_message(probe_log: Path, tmp_path: Path) -> None:
    exported = tmp_path / "probe.mcap"
    export(probe_log, exported)

    changes = read_exported(exported).messages["/state_changes"]

    near = next(m for m in changes if m.value["name"] == "near")
    seconds, nanoseconds = divmod(near.log_time, 1_000_000_000)
    assert near.value == {
        "timestamp": {"sec": seconds, "nsec": nanoseconds},
        "level": 2,
        "message": "near: far -> near",
        "name": "near",
        "file": "",
        "line": 0,
    }


def test_a_nan_or_infinite_float_is_left_out_and_listed_in_non_finite(
    record_probe: RecordFn, tmp_path: Path
) -> None:
    specials = [math.nan, math.inf, -math.inf, -0.0, 0.25]
    log = record_probe(states=[Probe(reading=value) for value in specials])
    exported = tmp_path / "specials.mcap"

    export(log, exported)

    read = read_exported(exported)
    states = [m.value for m in read.messages["/robot_state"]]
    assert [state.get("reading") for state in states] == [None, None, None, -0.0, 0.25]
    assert math.copysign(1.0, states[3]["reading"]) == -1.0
    assert [state.get("non_finite") for state in states] == [
        ["reading=NaN"],
        ["reading=Infinity"],
        ["reading=-Infinity"],
        None,
        None,
    ]
    properties = read.schemas["/robot_state"]["properties"]
    assert properties["reading"]["type"] == "number"
    assert properties["non_finite"] == {
        "type": "array",
        "items": {"type": "string"},
        "description": properties["non_finite"]["description"],
    }


def test_a_nested_robot_state_is_inlined_and_array_draws_are_json_text(
    tracked_log: Path, tmp_path: Path
) -> None:
    exported = tmp_path / "tracked.mcap"

    export(tracked_log, exported)

    read = read_exported(exported)
    schema = read.schemas["/robot_state"]
    assert "$defs" not in json.dumps(schema)
    assert "$ref" not in json.dumps(schema)
    assert schema["properties"]["pose"]["properties"]["x"] == {"type": "number"}
    assert schema["properties"]["ranges"] == {"type": "array", "items": {"type": "number"}}
    assert read.messages["/robot_state"][12].value == {
        "pose": {"x": 1.2, "heading": 0.0},
        "ranges": [0.5, 12.0],
    }
    (draw,) = read.messages["/random_numbers"][0].value["draws"]
    dtype, shape, data = json.loads(draw["value"])
    assert (draw["actor"], draw["kind"], dtype, shape) == ("scan", "uniform_array", "<f8", [3])
    assert len(base64.b64decode(data)) == 3 * 8
    assert json.loads(draw["params"]) == [0.0, 1.0, [3]]
    assert read.schemas["/outputs"]["properties"]["outputs"]["properties"]["noise"]["type"] == (
        "string"
    )
    noise = json.loads(read.messages["/outputs"][0].value["outputs"]["noise"])
    assert len(noise) == 3


def test_a_nan_in_a_nested_field_is_left_out_and_an_array_holding_one_is_number_texts(
    tmp_path: Path,
) -> None:
    log = tmp_path / "gaps.beatlog"
    states = [
        Tracked(pose=Pose(x=math.nan, heading=0.5), ranges=[0.5, math.inf]),
        Tracked(pose=Pose(x=1.0), ranges=[0.5, 2.0]),
    ]
    with Recorder(log, PriorityArbiter([Scan()], robot_state=Tracked), seed=3) as recorder:
        for state in states:
            recorder.step(PERIOD_NS, state)
    exported = tmp_path / "gaps.mcap"

    export(log, exported)

    read = read_exported(exported)
    first, second = (m.value for m in read.messages["/robot_state"])
    assert first == {
        "pose": {"heading": 0.5},
        "ranges": ["0.5", "Infinity"],
        "non_finite": ["pose.x=NaN"],
    }
    assert second == {"pose": {"x": 1.0, "heading": 0.0}, "ranges": ["0.5", "2.0"]}
    assert read.schemas["/robot_state"]["properties"]["ranges"] == {
        "type": "array",
        "items": {
            "type": "string",
            "description": "A number as its text (0.5); NaN and ±inf as NaN, Infinity and "
            "-Infinity.",
        },
    }


class Blip(msgspec.Struct):
    x: float = 0.0


class Rich(RobotState, kw_only=True):
    """A robot state with every kind of field a msgspec schema can declare."""

    mode: Literal["dock", "roam"] = "dock"
    level: int | None = None
    offset: float | None = None
    pair: tuple[int, float] = (1, 2.0)
    gains: dict[str, float] = msgspec.field(default_factory=dict)
    grid: list[list[float]] = msgspec.field(default_factory=list)
    maybe: list[float | None] = msgspec.field(default_factory=list)
    blob: bytes = b""
    blips: list[Blip] = msgspec.field(default_factory=list)


class Still:
    name = "still"
    state: BehaviorState = "idle"

    def step(self, rs: Rich, ctx: Context) -> Outputs | None:
        return None


def test_fields_the_viewers_cannot_type_are_json_text_and_nulls_are_left_out(
    tmp_path: Path,
) -> None:
    log = tmp_path / "rich.beatlog"
    state = Rich(
        mode="roam",
        offset=0.5,
        gains={"kp": math.nan},
        grid=[[1.0], [2.0, 3.0]],
        maybe=[1.0, None],
        blob=b"\x00\x01",
        blips=[Blip(1.0), Blip(math.nan)],
    )
    with Recorder(log, PriorityArbiter([Still()], robot_state=Rich), seed=1) as recorder:
        recorder.step(PERIOD_NS, state)
    exported = tmp_path / "rich.mcap"

    export(log, exported)

    read = read_exported(exported)
    properties = read.schemas["/robot_state"]["properties"]
    types = {name: field["type"] for name, field in properties.items()}
    assert types == {
        "mode": "string",
        "level": "integer",
        "offset": "number",
        "pair": "string",
        "gains": "string",
        "grid": "string",
        "maybe": "string",
        "blob": "string",
        "blips": "array",
        "non_finite": "array",
    }
    assert properties["blob"]["contentEncoding"] == "base64"
    assert properties["blips"]["items"] == {
        "type": "object",
        "properties": {"x": {"type": "number"}},
    }
    (message,) = (m.value for m in read.messages["/robot_state"])
    assert message == {
        "mode": "roam",
        "offset": 0.5,
        "pair": "[1,2.0]",
        "gains": '{"kp":"NaN"}',
        "grid": "[[1.0],[2.0,3.0]]",
        "maybe": "[1.0,null]",
        "blob": "AAE=",
        "blips": [{"x": 1.0}, {}],
        "non_finite": ["blips[1].x=NaN"],
    }


def test_a_recursive_robot_state_type_is_json_text_where_it_recurs(tmp_path: Path) -> None:
    node = {
        "type": "object",
        "properties": {
            "value": {"type": "number"},
            "child": {"anyOf": [{"$ref": "#/$defs/Node"}, {"type": "null"}]},
        },
    }
    tree = {"value": 1.0, "child": {"value": 2.0, "child": {"value": 3.0, "child": None}}}
    log = craft_log(
        tmp_path / "tree.beatlog",
        [
            header_message(robot_state_schema={"$ref": "#/$defs/Node", "$defs": {"Node": node}}),
            LogMessage(CYCLES_TOPIC, PERIOD_NS, msgspec.msgpack.encode([0, [cycle(state=tree)]])),
            end_message(1, PERIOD_NS),
        ],
    )
    exported = tmp_path / "tree.mcap"

    export(log, exported)

    read = read_exported(exported)
    properties = read.schemas["/robot_state"]["properties"]
    assert properties["value"] == {"type": "number"}
    assert properties["child"]["type"] == "string"  # a node inside a node
    (message,) = (m.value for m in read.messages["/robot_state"])
    assert message == {
        "value": 1.0,
        "child": '{"value":2.0,"child":{"value":3.0,"child":null}}',
    }


def test_a_robot_state_without_a_schema_is_typed_from_the_log(tmp_path: Path) -> None:
    states = [{"level": 1, "name": "a"}, {"level": 0.5, "name": 2, "on": True}]
    log = craft_cycles(tmp_path / "bare.beatlog", [cycle(state=state) for state in states])
    exported = tmp_path / "bare.mcap"

    export(log, exported)

    read = read_exported(exported)
    properties = read.schemas["/robot_state"]["properties"]
    assert {name: field["type"] for name, field in properties.items()} == {
        "level": "number",
        "name": "string",
        "on": "boolean",
        "non_finite": "array",
    }
    assert [m.value for m in read.messages["/robot_state"]] == [
        {"level": 1, "name": '"a"'},
        {"level": 0.5, "name": "2", "on": True},
    ]


def test_outputs_are_typed_from_a_first_read_of_the_log(tmp_path: Path) -> None:
    outputs: list[dict[str, Any]] = [
        {"speed": 1, "mode": "dock", "mixed": 1, "turn": [0.1, 0.2], "on": True, "gone": None},
        {"speed": math.nan, "mode": "roam", "mixed": "a"},
        {"speed": 0.5},
    ]
    log = craft_cycles(tmp_path / "out.beatlog", [cycle(outputs=o) for o in outputs])
    exported = tmp_path / "out.mcap"

    export(log, exported)

    read = read_exported(exported)
    declared = read.schemas["/outputs"]["properties"]["outputs"]["properties"]
    assert {name: field["type"] for name, field in declared.items()} == {
        "speed": "number",
        "mode": "string",
        "mixed": "string",
        "turn": "string",
        "on": "boolean",
        "gone": "string",
    }
    assert [m.value for m in read.messages["/outputs"]] == [
        {
            "cycle": 0,
            "outputs": {"speed": 1, "mode": "dock", "mixed": "1", "turn": "[0.1,0.2]", "on": True},
        },
        {
            "cycle": 1,
            "outputs": {"mode": "roam", "mixed": '"a"'},
            "non_finite": ["outputs.speed=NaN"],
        },
        {"cycle": 2, "outputs": {"speed": 0.5}},
    ]


def test_behavior_states_that_are_no_strings_are_json_text(tmp_path: Path) -> None:
    records = [
        cycle(),
        cycle(state_changes=[[0, 1, 2]]),
        cycle(state_changes=[[0, 2, True]]),
    ]
    batch = LogMessage(CYCLES_TOPIC, PERIOD_NS, msgspec.msgpack.encode([0, records]))
    log = craft_log(
        tmp_path / "gears.beatlog",
        [header_message(behaviors=["gear", "quiet"]), batch, end_message(3, 3 * PERIOD_NS)],
    )
    exported = tmp_path / "gears.mcap"

    export(log, exported)

    read = read_exported(exported)
    assert [m.value["state"] for m in read.messages["/behaviors/gear"]] == ["1", "2", "true"]
    assert [m.value["state"] for m in read.messages["/behaviors/quiet"]] == ["null"]


def test_a_robot_state_field_named_non_finite_is_one_line(beatlog: Beatlog, tmp_path: Path) -> None:
    log = craft_cycles(tmp_path / "clash.beatlog", [cycle(state={"non_finite": 1.0})])

    run = beatlog("export", log, "-o", tmp_path / "x.mcap")

    assert_error(
        run,
        f"{log}: robot-state field 'non_finite' has the name of the field that lists NaN and "
        "infinite values; export as a table instead",
    )
    assert not (tmp_path / "x.mcap").exists()


def test_without_a_system_there_is_no_divergence_channel(probe_log: Path, tmp_path: Path) -> None:
    exported = tmp_path / "probe.mcap"

    result = export(probe_log, exported)

    assert sorted(read_exported(exported).messages) == PROBE_TOPICS  # no /divergence
    assert not result.replayed
    assert result.divergence is None


def test_a_system_adds_its_first_divergence(
    beatlog: Beatlog, probe_log: Path, tmp_path: Path
) -> None:
    exported = tmp_path / "changed.mcap"

    run = beatlog(
        "export", probe_log, "-o", exported, "--system", "tests.conftest:probe_system_changed"
    )

    first = next(t for t, d in enumerate(distances(300)) if (d < 0.6) != (d < 0.5))
    assert run.code == 1  # diverged, and the export is written
    assert run.out == (
        f"exported 300 cycles of {probe_log} to {exported} (mcap); "
        f"first divergence at cycle {first} (state changes)\n"
    )
    (divergence,) = read_exported(exported).messages["/divergence"]
    assert (divergence.log_time, divergence.sequence) == (log_times(probe_log)[first], first)
    assert divergence.value["kind"] == "state changes"
    assert divergence.value["behavior"] == "arbiter"
    assert divergence.value["expected"] == []
    assert divergence.value["actual"] == [
        {"behavior": "arbiter", "before": "dice", "after": "near"},
        {"behavior": "near", "before": "far", "after": "near"},
    ]
    assert divergence.value["reproduce"].startswith("beatlog replay ")


def test_a_system_that_passes_adds_no_divergence(
    beatlog: Beatlog, probe_log: Path, tmp_path: Path
) -> None:
    exported = tmp_path / "same.mcap"

    run = beatlog("export", probe_log, "-o", exported, "--system", "tests.conftest:probe_system")

    assert (run.code, run.out) == (
        0,
        f"exported 300 cycles of {probe_log} to {exported} (mcap); the replay passed\n",
    )
    assert sorted(read_exported(exported).messages) == PROBE_TOPICS  # no /divergence


class Faster(Dice):
    """dice, but driving faster: outputs that differ with the same state changes."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        return {**(super().step(rs, ctx) or {}), "speed": 0.7}


def test_a_divergence_of_no_behavior_has_an_empty_behavior(probe_log: Path, tmp_path: Path) -> None:
    exported = tmp_path / "faster.mcap"

    result = export(
        probe_log, exported, system=PriorityArbiter([Near(), Faster()], robot_state=Probe)
    )

    (divergence,) = read_exported(exported).messages["/divergence"]
    assert result.divergence is not None
    assert result.divergence.behavior is None
    assert (divergence.value["kind"], divergence.value["behavior"]) == ("outputs", "")


def test_every_channel_of_an_export_is_one_the_viewers_parse(
    probe_log: Path, tmp_path: Path
) -> None:
    exported = tmp_path / "changed.mcap"
    export(probe_log, exported, system="tests.conftest:probe_system_changed")

    with exported.open("rb") as file:
        summary = make_reader(file).get_summary()
    assert summary is not None
    schemas = {
        channel.topic: json.loads(summary.schemas[channel.schema_id].data)
        for channel in summary.channels.values()
    }
    assert len(schemas) == 9  # the eight channels and /divergence
    for schema in schemas.values():
        check_viewer_schema(schema)


FOXGLOVE_LOG_LEVEL = {"oneOf": [{"title": "INFO", "const": 2}]}


@pytest.mark.parametrize(
    ("schema", "fragment"),
    [
        ({"type": "array", "items": {"type": "number"}}, '<root>: expected "type": "object"'),
        ({"type": "object"}, "<root>: an object needs a properties map"),
        ({"type": "object", "properties": {"x": {"type": ["number", "string"]}}}, "<root>.x"),
        ({"type": "object", "properties": {"x": {"type": "null"}}}, "unsupported type 'null'"),
        ({"type": "object", "properties": {"x": {}}}, "<root>.x: unsupported type None"),
        ({"type": "object", "properties": {"level": FOXGLOVE_LOG_LEVEL}}, "oneOf"),
        (
            {"type": "object", "properties": {"x": {"type": "string", "contentEncoding": "hex"}}},
            "unsupported contentEncoding",
        ),
        ({"type": "object", "properties": {"x": {"type": "array"}}}, "<root>.x[]: unsupported"),
        (
            {"type": "object", "properties": {"x": {"type": "array", "items": {"type": "array"}}}},
            "unsupported array item type 'array'",
        ),
        (
            {
                "type": "object",
                "properties": {
                    "x": {"type": "array", "items": {"type": "string", "contentEncoding": "base64"}}
                },
            },
            "an array item has a contentEncoding",
        ),
        (
            {
                "type": "object",
                "properties": {"p": {"type": "object", "properties": {"q": {"anyOf": []}}}},
            },
            "<root>.p.q: unsupported type None",
        ),
        (
            {
                "type": "object",
                "properties": {"ps": {"type": "array", "items": {"type": "object"}}},
            },
            "<root>.ps[]: an object needs a properties map",
        ),
    ],
)
def test_the_viewer_rules_refuse_what_the_viewers_refuse(
    schema: dict[str, Any], fragment: str
) -> None:
    with pytest.raises(ViewerSchemaError, match=fragment.replace("[", r"\[").replace("]", r"\]")):
        check_viewer_schema(schema)


def test_the_viewer_rules_accept_what_the_viewers_read() -> None:
    check_viewer_schema(
        {
            "type": "object",
            "properties": {
                "on": {"type": "boolean"},
                "name": {"type": "string"},
                "blob": {"type": "string", "contentEncoding": "base64"},
                "x": {"type": "number"},
                "n": {"type": "integer"},
                "pose": {"type": "object", "properties": {"x": {"type": "number"}}},
                "names": {"type": "array", "items": {"type": "string"}},
                "poses": {
                    "type": "array",
                    "items": {"type": "object", "properties": {"x": {"type": "number"}}},
                },
            },
        }
    )


def test_a_truncated_log_is_exported_up_to_its_last_cycle(beatlog: Beatlog, tmp_path: Path) -> None:
    log = craft_log(tmp_path / "cut.beatlog", [header_message(), *cycle_messages(20)])
    exported = tmp_path / "cut.mcap"

    run = beatlog("export", log, "-o", exported)

    assert (run.code, run.out) == (
        0,
        f"exported 20 cycles of {log} to {exported} (mcap); "
        "the log is truncated at cycle 20: the log has no end record\n",
    )
    assert len(read_exported(exported).messages["/robot_state"]) == 20
    assert mcap_metadata(exported) == {
        "beatlog": {
            "log": "cut.beatlog",
            "format_version": str(FORMAT_VERSION),
            "robot_id": "bench",
            "software_version": "test",
            "python_version": "unknown",
            "system": "",
            "robot_state_type": "tests.crafting.Gauge",
            "period_ns": str(PERIOD_NS),
            "start_time_ns": "0",
            "cycles": "20",
            "complete": "false",
            "status": "truncated at cycle 20: the log has no end record",
            "log_time": LOG_TIME,
        }
    }


@pytest.mark.parametrize("log", one_by_default(COMMITTED, SMALL_COMMITTED, committed_id))
def test_every_committed_dtc_exports_for_the_viewers_and_validates(
    log: Path, tmp_path: Path
) -> None:
    exported = tmp_path / f"{log.stem}.mcap"

    result = export(log, exported)

    read = read_exported(exported)  # checks every channel's schema with the viewers' rules
    for schema in read.schemas.values():
        check_viewer_schema(schema)
    assert result.status == LogStatus(complete=True, cycles=result.cycles)
    assert all(len(read.messages[topic]) == result.cycles for topic in PER_CYCLE_TOPICS)


def test_the_validator_checks_each_shape_of_message_with_the_standard_one() -> None:
    """Validating each shape once loses nothing: a number past a bound, a float for an
    integer or a key too many makes another shape, which is validated again."""
    checker = Validator(
        {
            "type": "object",
            "properties": {"cycle": {"type": "integer", "minimum": 0}},
            "required": ["cycle"],
            "additionalProperties": False,
        }
    )
    checker.validate({"cycle": 3})
    checker.validate({"cycle": 4.0})

    for invalid in ({"cycle": -1}, {"cycle": 2.5}, {"cycle": 3, "more": 1}, {}):
        with pytest.raises(ValidationError):
            checker.validate(invalid)


def test_the_committed_suites_are_found() -> None:
    assert {path.parts[-3] for path in COMMITTED} == {"dog", "trees"}
    assert len(COMMITTED) >= 22


def test_messages_are_stamped_with_the_recording_start_plus_robot_time(
    record_probe: RecordFn, tmp_path: Path
) -> None:
    start_ns = 1_700_000_000_123_456_789
    log = record_probe(start_time_ns=start_ns)
    exported = tmp_path / "probe.mcap"

    export(log, exported)

    read = read_exported(exported)
    times = [start_ns + time for time in robot_times(log)]
    assert [m.log_time for m in read.messages["/robot_state"]] == times
    change = read.messages["/state_changes"][0]
    assert change.value["timestamp"] == {
        "sec": change.log_time // 1_000_000_000,
        "nsec": change.log_time % 1_000_000_000,
    }
    assert change.log_time in times
    header = summarize(log).header
    assert mcap_metadata(exported) == {
        "beatlog": {
            "log": "probe.beatlog",
            "format_version": str(FORMAT_VERSION),
            "robot_id": "robot",
            "software_version": "test",
            "python_version": platform.python_version(),
            "system": "tests.conftest:probe_system",
            "robot_state_type": header.robot_state_type,
            "period_ns": str(header.period_ns),
            "start_time_ns": str(start_ns),
            "cycles": "300",
            "complete": "true",
            "status": "complete",
            "log_time": LOG_TIME,
        }
    }


def test_samples_are_exported_on_a_channel_per_sensor(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "sensed.beatlog", 30)
    exported = tmp_path / "sensed.mcap"

    export(log, exported)

    read = read_exported(exported)
    ranges = read.messages["/samples/range"]
    assert read.schema_names["/samples/range"] == "beatlog.Sample/range"
    assert read.schemas["/samples/range"]["properties"]["value"] == {
        "type": "array",
        "items": {"type": "number"},
    }
    assert [(m.log_time, m.sequence) for m in ranges] == [
        (time, cycle) for cycle, time in enumerate(log_times(log))
    ]
    assert [m.value for m in ranges[:2]] == [
        {"cycle": 0, "stamp_ns": 0, "value": [distances(30)[0], 1]},
        {"cycle": 1, "stamp_ns": PERIOD_NS, "value": [distances(30)[1], 1]},
    ]


def test_samples_are_typed_from_the_log_and_keep_the_numbers_beside_a_nan(
    tmp_path: Path,
) -> None:
    log = tmp_path / "bag.beatlog"
    cycles = [
        [
            Sample("/scan", 10, {"ranges": [0.5, math.nan], "frame_id": "laser"}),
            Sample("/imu", 11, 1),
            Sample("blobs", 12, [b"\x00"]),
        ],
        [
            Sample("/scan", 20, {"ranges": [0.25, 2], "frame_id": "laser", "intensity": None}),
            Sample("/imu", 21, math.inf),
            Sample("/gps", 22, None),
        ],
    ]
    with Recorder(log, probe_system(), seed=1, log_samples=True) as recorder:
        for samples in cycles:
            recorder.step(PERIOD_NS, Probe(), samples)
    exported = tmp_path / "bag.mcap"

    export(log, exported)

    read = read_exported(exported)
    values = {
        topic: [m.value for m in messages]
        for topic, messages in read.messages.items()
        if topic.startswith("/samples/")
    }
    assert values == {
        "/samples/scan": [
            {"cycle": 0, "stamp_ns": 10, "value": {"ranges": ["0.5", "NaN"], "frame_id": "laser"}},
            {"cycle": 1, "stamp_ns": 20, "value": {"ranges": ["0.25", "2"], "frame_id": "laser"}},
        ],
        "/samples/imu": [
            {"cycle": 0, "stamp_ns": 11, "value": 1},
            {"cycle": 1, "stamp_ns": 21, "non_finite": ["value=Infinity"]},
        ],
        "/samples/blobs": [{"cycle": 0, "stamp_ns": 12, "value": '["AA=="]'}],
        "/samples/gps": [{"cycle": 1, "stamp_ns": 22}],
    }
    types = {topic: read.schemas[topic]["properties"]["value"]["type"] for topic in values}
    assert types == {
        "/samples/scan": "object",
        "/samples/imu": "number",
        "/samples/blobs": "string",
        "/samples/gps": "string",
    }
    scan = read.schemas["/samples/scan"]["properties"]["value"]["properties"]
    assert {name: field["type"] for name, field in scan.items()} == {
        "ranges": "array",
        "frame_id": "string",
    }
    assert scan["ranges"]["items"]["type"] == "string"


def test_a_log_imported_from_a_bag_lines_up_with_the_bag(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "bag", sonars=30, speeds=5)
    imported = import_bag(
        bag, tmp_path / "bag.beatlog", system=probe_system(), perception=perception()
    )
    exported = tmp_path / "bag.mcap"

    export(imported.log, exported)

    sonar = read_exported(exported).messages["/samples/sonar"]
    stamps = [m.value["stamp_ns"] for m in sonar]
    assert stamps == [START_NS + index * SONAR_EVERY_NS for index in range(30)]
    period_ns = summarize(imported.log).header.period_ns
    assert all(m.value["stamp_ns"] < m.log_time <= m.value["stamp_ns"] + period_ns for m in sonar)
    assert sonar[3].value["value"] == {
        "header": {"stamp": {"sec": 3, "nanosec": 0}, "frame_id": "sonar_link"},
        "range": pytest.approx(distances(30)[3]),
        "echo": base64.b64encode(bytes([3, 7, 0])).decode(),
        "mount": [0.1, 0.0, 0.2],
        "label": "front",
    }


def test_topics_that_begin_late_in_the_bag_line_up_with_it(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "bag", sonars=30, speeds=5, logs=4)  # /rosout a second in
    imported = import_bag(
        bag,
        tmp_path / "bag.beatlog",
        system=probe_system(),
        perception=perception(),
        topics=["/rosout"],
    )
    exported = tmp_path / "bag.mcap"

    export(imported.log, exported)

    logs = read_exported(exported).messages["/samples/rosout"]
    period_ns = summarize(imported.log).header.period_ns
    assert [m.log_time for m in logs] == [  # the end of the heartbeat that took it
        LOGS_FROM_NS + ((m.value["stamp_ns"] - LOGS_FROM_NS) // period_ns + 1) * period_ns
        for m in logs
    ]


def test_a_log_imported_by_clock_topic_lines_up_with_the_bag(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "bag", sonars=30, speeds=5, ticks=10)
    ticks = [START_NS + (index + 1) * TICK_EVERY_NS for index in range(10)]
    imported = import_bag(
        bag,
        tmp_path / "bag.beatlog",
        system=probe_system(),
        perception=perception(),
        clock_topic="/tick",
    )
    exported = tmp_path / "bag.mcap"

    export(imported.log, exported)

    sonar = read_exported(exported).messages["/samples/sonar"]
    assert len(sonar) == 30
    assert (
        [m.log_time for m in sonar]
        == [  # the clock message that ends its heartbeat
            min(tick for tick in ticks[1:] if tick >= m.value["stamp_ns"]) for m in sonar
        ]
    )


class Placed(RobotState, kw_only=True):
    """A robot state with its pose at the top level, as the rover's."""

    x: float = 0.0
    y: float = 0.0
    heading: float = 0.0


class Pose3(msgspec.Struct):
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    yaw: float = 0.0


class Posed(RobotState, kw_only=True):
    """A robot state with its pose in a ``pose`` struct, z and yaw included."""

    pose: Pose3 = msgspec.field(default_factory=Pose3)


class Idle:
    name = "idle"
    state: BehaviorState = "idle"

    def step(self, rs: RobotState, ctx: Context) -> Outputs | None:
        return None


@pytest.mark.parametrize(
    ("state_type", "states", "z"),
    [
        (
            Placed,
            [Placed(x=1.0, y=2.0, heading=math.pi / 2), Placed(x=math.nan), Placed(x=3.0)],
            0.0,
        ),
        (
            Posed,
            [
                Posed(pose=Pose3(x=1.0, y=2.0, z=0.5, yaw=math.pi / 2)),
                Posed(pose=Pose3(yaw=math.inf)),
                Posed(pose=Pose3(x=3.0, z=0.5)),
            ],
            0.5,
        ),
    ],
    ids=["top-level", "in-pose"],
)
def test_a_robot_state_with_a_pose_is_a_foxglove_frame_transform(
    state_type: type[RobotState], states: list[RobotState], z: float, tmp_path: Path
) -> None:
    log = tmp_path / "placed.beatlog"
    system = PriorityArbiter([Idle()], robot_state=state_type)
    with Recorder(log, system, seed=1, start_time_ns=5_000_000_000) as recorder:
        for state in states:
            recorder.step(PERIOD_NS, state)
    exported = tmp_path / "placed.mcap"

    export(log, exported)

    read = read_exported(exported)
    assert read.schema_names["/tf"] == "foxglove.FrameTransform"
    schema = read.schemas["/tf"]
    assert schema["required"] == [
        "timestamp",
        "parent_frame_id",
        "child_frame_id",
        "translation",
        "rotation",
    ]
    assert schema["properties"]["translation"]["required"] == ["x", "y", "z"]
    assert schema["properties"]["rotation"]["required"] == ["x", "y", "z", "w"]
    first, third = read.messages["/tf"]  # none where the pose holds a NaN or inf
    assert (first.sequence, third.sequence) == (0, 2)
    assert first.value == {
        "timestamp": {"sec": 5, "nsec": PERIOD_NS},
        "parent_frame_id": "odom",
        "child_frame_id": "base_link",
        "translation": {"x": 1.0, "y": 2.0, "z": z},
        "rotation": {"x": 0.0, "y": 0.0, "z": math.sin(math.pi / 4), "w": math.cos(math.pi / 4)},
    }
    assert third.value["translation"] == {"x": 3.0, "y": 0.0, "z": z}
    assert third.value["rotation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}


def test_a_robot_state_without_x_y_and_a_heading_has_no_pose(
    tracked_log: Path, tmp_path: Path
) -> None:
    exported = tmp_path / "tracked.mcap"

    export(tracked_log, exported)  # its pose has x and heading, no y

    assert sorted(read_exported(exported).messages) == [  # no /tf
        *("/behaviors/arbiter", "/behaviors/scan"),
        *("/heartbeat", "/outputs", "/random_numbers", "/robot_state", "/state_changes"),
    ]


# tables


def test_a_parquet_table_has_a_row_per_cycle_and_a_column_per_field(
    beatlog: Beatlog, probe_log: Path, tmp_path: Path
) -> None:
    table_path = tmp_path / "probe.parquet"

    run = beatlog("export", probe_log, "-o", table_path, "--format", "parquet")

    assert run.code == 0
    table = pq.read_table(table_path)
    assert table.column_names == [
        "cycle",
        "time_ns",
        "heartbeat_ns",
        "distance",
        "reading",
        "behavior.arbiter",
        "behavior.near",
        "behavior.dice",
        "out.speed",
        "out.time",
        "draws",
    ]
    columns = table.to_pydict()
    assert columns["cycle"] == list(range(300))
    assert columns["time_ns"] == robot_times(probe_log)
    assert columns["distance"] == distances(300)
    assert sum(columns["draws"]) == sum(summarize(probe_log).random_draws.values())
    first_near = next(t for t, d in enumerate(distances(300)) if d < 0.5)
    assert columns["behavior.near"][first_near - 1 : first_near + 1] == ["far", "near"]


def test_a_csv_table_has_the_same_rows_and_writes_special_floats_as_python_does(
    record_probe: RecordFn, tmp_path: Path
) -> None:
    log = record_probe(states=[Probe(reading=value) for value in (math.nan, math.inf, 1.5)])
    table_path = tmp_path / "specials.csv"

    result = export(log, table_path, format=ExportFormat.CSV)

    with table_path.open(encoding="utf-8", newline="") as file:
        rows = list(csv.DictReader(file))
    assert result.cycles == len(rows) == 3
    assert [row["reading"] for row in rows] == ["nan", "inf", "1.5"]
    assert [row["cycle"] for row in rows] == ["0", "1", "2"]


def test_nested_fields_are_dotted_columns_lists_of_numbers_lists_other_lists_json_text(
    tracked_log: Path, tmp_path: Path
) -> None:
    parquet_path = tmp_path / "tracked.parquet"

    export(tracked_log, parquet_path, format="parquet")

    columns = pq.read_table(parquet_path).to_pydict()
    assert columns["pose.x"][12] == 1.2
    assert columns["ranges"][12] == [0.5, 12.0]
    assert len(json.loads(columns["out.noise"][0])) == 3
    assert columns["behavior.scan"][:12] == ["idle"] * 11 + ["busy"]


def test_parquet_keeps_special_floats(record_probe: RecordFn, tmp_path: Path) -> None:
    log = record_probe(states=[Probe(reading=value) for value in (math.nan, -math.inf)])
    parquet_path = tmp_path / "specials.parquet"

    export(log, parquet_path, format=ExportFormat.PARQUET)

    reading = pq.read_table(parquet_path).to_pydict()["reading"]
    assert math.isnan(reading[0])
    assert reading[1] == -math.inf


def craft_cycles(path: Path, records: list[list[Any]]) -> Path:
    """A complete log of these cycle records (see ``tests.factories.cycle``), one batch."""
    batch = LogMessage(CYCLES_TOPIC, records[0][0], msgspec.msgpack.encode([0, records]))
    total_ns = sum(record[0] for record in records)
    return craft_log(path, [header_message(), batch, end_message(len(records), total_ns)])


def test_a_parquet_column_of_mixed_types_holds_json_text(tmp_path: Path) -> None:
    modes: list[Any] = [1, "dock", None]
    log = craft_cycles(tmp_path / "mixed.beatlog", [cycle(outputs={"mode": m}) for m in modes])
    parquet_path = tmp_path / "mixed.parquet"

    export(log, parquet_path, format=ExportFormat.PARQUET)

    assert pq.read_table(parquet_path).to_pydict()["out.mode"] == ["1", '"dock"', None]


def test_a_robot_state_field_named_like_another_column_is_one_line(
    beatlog: Beatlog, tmp_path: Path
) -> None:
    log = craft_cycles(tmp_path / "clash.beatlog", [cycle(state={"cycle": 1.0})] * 2)
    table_path = tmp_path / "clash.csv"

    run = beatlog("export", log, "-o", table_path, "--format", "csv")

    assert_error(
        run,
        f"{log}: robot-state field 'cycle' has the name of another column; export as MCAP instead",
    )
    assert not table_path.exists()


class Surveyed(RobotState, kw_only=True):
    x: float = 0.0
    ranges: list[float] = msgspec.field(default_factory=list)
    fix: int | None = None


class Watch:
    """No state until the robot is more than 2 m out, 'away' from then on."""

    name = "watch"

    def __init__(self) -> None:
        self.state: BehaviorState = None

    def step(self, rs: Surveyed, ctx: Context) -> Outputs | None:
        if rs.x > 2.0:
            self.state = "away"
        return {"speed": 0.5}


@pytest.fixture
def survey_tables(tmp_path: Path) -> Path:
    """A folder of the Parquet exports of two logs of one system: in the calm one the
    watch behavior's state and the fix are always None and no range is NaN."""
    logs = {
        "a-calm": [Surveyed(x=0.5, ranges=[1.0, 2.0])] * 3,
        "b-busy": [Surveyed(x=3.0, ranges=[math.nan, 2.0], fix=4)] * 2,
    }
    tables = tmp_path / "tables"
    tables.mkdir()
    for name, states in logs.items():
        log = tmp_path / f"{name}.beatlog"
        with Recorder(log, PriorityArbiter([Watch()], robot_state=Surveyed), seed=1) as recorder:
            for state in states:
                recorder.step(PERIOD_NS, state)
        export(log, tables / f"{name}.parquet")
    return tables


def test_parquet_exports_of_one_system_share_a_schema_a_dataset_reads(
    survey_tables: Path,
) -> None:
    table = ds.dataset(survey_tables, format="parquet").to_table()

    calm, busy = (pq.read_schema(path) for path in sorted(survey_tables.iterdir()))
    assert calm.equals(busy, check_metadata=False)
    assert dict(zip(calm.names, map(str, calm.types), strict=True)) == {
        "cycle": "int64",
        "time_ns": "int64",
        "heartbeat_ns": "int64",
        "x": "double",
        "ranges": "list<element: double>",
        "fix": "int64",
        "behavior.arbiter": "string",
        "behavior.watch": "string",
        "out.speed": "double",
        "draws": "int64",
    }
    columns = table.to_pydict()
    assert columns["behavior.watch"] == [None, None, None, "away", "away"]
    assert columns["fix"] == [None, None, None, 4, 4]
    assert columns["ranges"][:3] == [[1.0, 2.0]] * 3
    assert [math.isnan(busy_ranges[0]) for busy_ranges in columns["ranges"][3:]] == [True, True]
    assert [busy_ranges[1] for busy_ranges in columns["ranges"][3:]] == [2.0, 2.0]


def test_duckdb_reads_a_glob_of_parquet_exports_without_union_by_name(
    survey_tables: Path,
) -> None:
    query = (
        'select count(*), count("behavior.watch"), count(fix), sum(len(ranges)) '
        f"from read_parquet('{survey_tables}/*.parquet')"
    )

    with duckdb.connect() as connection:
        assert connection.execute(query).fetchall() == [(5, 2, 2, 10)]


def test_parquet_metadata_names_the_log_and_where_it_ends(tmp_path: Path) -> None:
    log = craft_log(tmp_path / "cut.beatlog", [header_message(), *cycle_messages(20)])
    table_path = tmp_path / "cut.parquet"

    export(log, table_path)

    metadata = pq.read_schema(table_path).metadata
    assert {key.decode(): value.decode() for key, value in metadata.items()} == {
        "beatlog.log": "cut.beatlog",
        "beatlog.format_version": str(FORMAT_VERSION),
        "beatlog.robot_id": "bench",
        "beatlog.software_version": "test",
        "beatlog.python_version": "unknown",
        "beatlog.system": "",
        "beatlog.robot_state_type": "tests.crafting.Gauge",
        "beatlog.period_ns": str(PERIOD_NS),
        "beatlog.start_time_ns": "0",
        "beatlog.cycles": "20",
        "beatlog.complete": "false",
        "beatlog.status": "truncated at cycle 20: the log has no end record",
    }


def test_a_value_unlike_its_declared_type_is_one_line(beatlog: Beatlog, tmp_path: Path) -> None:
    schema = {"type": "object", "properties": {"level": {"type": "number"}}}
    log = craft_log(
        tmp_path / "liar.beatlog",
        [
            header_message(robot_state_schema=schema),
            LogMessage(
                CYCLES_TOPIC, PERIOD_NS, msgspec.msgpack.encode([0, [cycle(state={"level": "x"})]])
            ),
            end_message(1),
        ],
    )
    table_path = tmp_path / "liar.parquet"

    run = beatlog("export", log, "-o", table_path)

    assert_error_matching(  # pyarrow's words for the value it cannot convert follow
        run, re.escape(f"{log}: column 'level' does not hold the double it is declared as: ") + ".+"
    )
    assert not table_path.exists()


# bad input: exit 2 and one line


def test_a_missing_log_is_one_line(beatlog: Beatlog, tmp_path: Path) -> None:
    run = beatlog("export", tmp_path / "lost.beatlog", "-o", tmp_path / "x.mcap")

    assert_error(run, f"{tmp_path / 'lost.beatlog'}: no such file")
    assert not (tmp_path / "x.mcap").exists()


def test_a_file_that_is_no_session_log_is_one_line(beatlog: Beatlog, tmp_path: Path) -> None:
    junk = tmp_path / "junk.beatlog"
    junk.write_bytes(b"not an mcap file at all")

    run = beatlog("export", junk, "-o", tmp_path / "x.mcap")

    assert_error(run, f"{junk}: not a session log (not an MCAP file)")


def test_an_unknown_format_is_one_line(beatlog: Beatlog, probe_log: Path, tmp_path: Path) -> None:
    run = beatlog("export", probe_log, "-o", tmp_path / "x.xls", "--format", "xls")

    assert_error(
        run,
        "argument --format: invalid choice: 'xls' (choose from 'mcap', 'parquet', 'csv') "
        "(see 'beatlog export --help')",
    )


def test_the_library_names_the_formats_it_writes(probe_log: Path, tmp_path: Path) -> None:
    with pytest.raises(
        ExportError, match="cannot export as 'xls'; choose one of mcap, parquet, csv"
    ):
        export(probe_log, tmp_path / "x.xls", format="xls")


def test_a_system_for_a_table_is_one_line(
    beatlog: Beatlog, probe_log: Path, tmp_path: Path
) -> None:
    run = beatlog(
        "export",
        probe_log,
        "-o",
        tmp_path / "x.csv",
        "--format",
        "csv",
        "--system",
        "tests.conftest:x",
    )

    assert_error(run, "a replay's divergence is exported to MCAP only, not csv")


def test_a_bad_system_is_one_line(beatlog: Beatlog, probe_log: Path, tmp_path: Path) -> None:
    run = beatlog(
        "export", probe_log, "-o", tmp_path / "x.mcap", "--system", "tests.nowhere:system"
    )

    assert_error_matching(
        run, re.escape("'tests.nowhere:system': ") + cannot_import("tests.nowhere")
    )


def test_an_unwritable_output_is_one_line_naming_it(
    beatlog: Beatlog, probe_log: Path, tmp_path: Path
) -> None:
    output = tmp_path / "no" / "such" / "x.mcap"

    run = beatlog("export", probe_log, "-o", output)

    assert_error(run, f"{output}: cannot write: No such file or directory")


def test_the_log_itself_is_never_the_output(beatlog: Beatlog, probe_log: Path) -> None:
    before = probe_log.read_bytes()

    run = beatlog("export", probe_log, "-o", probe_log, "--format", "mcap")

    assert_error(run, f"{probe_log}: is the session log being exported; name another file")
    assert probe_log.read_bytes() == before


def test_a_schema_reference_the_header_lacks_is_one_line(beatlog: Beatlog, tmp_path: Path) -> None:
    log = craft_log(
        tmp_path / "dangling.beatlog",
        [
            header_message(robot_state_schema={"$ref": "#/definitions/Gone"}),
            *cycle_messages(2),
            end_message(2),
        ],
    )

    run = beatlog("export", log, "-o", tmp_path / "x.mcap")

    assert_error(
        run, f"{log}: the robot-state schema refers to '#/definitions/Gone', which it lacks"
    )
    assert not (tmp_path / "x.mcap").exists()


def test_a_schema_that_inlines_exponentially_is_one_line(beatlog: Beatlog, tmp_path: Path) -> None:
    defs = {
        f"T{level}": {
            "type": "object",
            "properties": {
                "a": {"$ref": f"#/$defs/T{level + 1}"},
                "b": {"$ref": f"#/$defs/T{level + 1}"},
            },
        }
        for level in range(40)
    }
    defs["T40"] = {"type": "number"}
    log = craft_log(
        tmp_path / "bomb.beatlog",
        [
            header_message(robot_state_schema={"$ref": "#/$defs/T0", "$defs": defs}),
            *cycle_messages(1),
            end_message(1),
        ],
    )

    run = beatlog("export", log, "-o", tmp_path / "x.mcap")

    assert_error(run, f"{log}: the robot-state schema inlines to more than 100000 nodes")


def test_without_pyarrow_parquet_says_which_extra_to_install(
    beatlog: Beatlog, probe_log: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    for name in [name for name in sys.modules if name.startswith("pyarrow")]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, "pyarrow", None)

    run = beatlog("export", probe_log, "-o", tmp_path / "x.parquet", "--format", "parquet")

    assert_error(run, 'Parquet export needs pyarrow (pip install "beatlog[export]")')


@pytest.mark.parametrize("suffix", [".mcap", ".parquet", ".csv"])
def test_the_output_suffix_picks_the_format(
    beatlog: Beatlog, probe_log: Path, tmp_path: Path, suffix: str
) -> None:
    output = tmp_path / f"probe{suffix.upper()}"

    run = beatlog("export", probe_log, "-o", output)

    format = suffix.removeprefix(".")
    assert (run.code, run.out) == (
        0,
        f"exported 300 cycles of {probe_log} to {output} ({format})\n",
    )
    if format == "mcap":
        assert len(read_exported(output).messages["/robot_state"]) == 300
    elif format == "parquet":
        assert pq.read_table(output).num_rows == 300
    else:
        assert len(output.read_text().splitlines()) == 301


def test_a_format_the_suffix_contradicts_is_one_line_and_nothing_is_written(
    beatlog: Beatlog, probe_log: Path, tmp_path: Path
) -> None:
    table_path = tmp_path / "probe.parquet"
    export(probe_log, table_path)
    before = table_path.read_bytes()

    run = beatlog("export", probe_log, "-o", table_path, "--format", "mcap")

    assert_error(
        run,
        f"{table_path}: a .parquet file is not written as mcap; name it .mcap or export as parquet",
    )
    assert table_path.read_bytes() == before


def test_an_output_suffix_of_no_format_needs_the_format_named(
    beatlog: Beatlog, probe_log: Path, tmp_path: Path
) -> None:
    output = tmp_path / "probe.txt"

    refused = beatlog("export", probe_log, "-o", output)
    named = beatlog("export", probe_log, "-o", output, "--format", "csv")

    assert_error(
        refused,
        f"{output}: an export is written as .mcap, .parquet, .csv, not suffix .txt; "
        "or name the format",
    )
    assert named.code == 0
    assert output.read_text().startswith("cycle,time_ns,heartbeat_ns,distance,")


def test_a_log_time_past_what_mcap_can_stamp_is_one_line(beatlog: Beatlog, tmp_path: Path) -> None:
    late = 2**63 + 1
    log = craft_log(
        tmp_path / "late.beatlog",
        [
            header_message(start_time_ns=2**63 - 1),
            LogMessage(CYCLES_TOPIC, late, msgspec.msgpack.encode([0, [cycle(late)]])),
            end_message(1, late),
        ],
    )
    output = tmp_path / "late.mcap"

    run = beatlog("export", log, "-o", output)

    assert_error(run, f"{log}: cycle 0 ends past the latest time MCAP can stamp")
    assert not output.exists()


def one_cycle_log(path: Path, record: list[Any], **header: Any) -> Path:
    """A complete log of the one cycle ``record``, its header changed by ``header``."""
    batch = LogMessage(CYCLES_TOPIC, PERIOD_NS, msgspec.msgpack.encode([0, [record]]))
    return craft_log(path, [header_message(**header), batch, end_message(1)])


# How deep a value may nest before reading or writing it runs out of recursion depends on
# the interpreter (Python 3.12 reads deeper than 3.11), so these walk depths across both
# bounds: each export writes its file or refuses in one line, and some depth passes the
# reader and is refused by the export itself.
NESTINGS = (500, 700, 1000, 1200, 1500, 3000, 100_000)
READER_REFUSES = "damaged the batch after cycle 0: maximum recursion depth exceeded"


def refusals_across_nestings(
    beatlog: Beatlog, tmp_path: Path, log_of: Callable[[Path, msgspec.Raw], Path]
) -> set[str]:
    """What ``export`` said of the log ``log_of`` writes holding a value nested each of
    :data:`NESTINGS` deep, up to any " while ...": "" where it wrote the file, or the one
    line of its refusal, having left no file."""
    refusals = set()
    for depth in NESTINGS:
        log = log_of(tmp_path / f"deep{depth}.beatlog", deeply_nested(depth))
        output = tmp_path / f"deep{depth}.mcap"
        run = beatlog("export", log, "-o", output)
        assert (run.code, run.out, run.err.count("\n")) in [(0, run.out, 0), (2, "", 1)], run
        assert output.exists() is (run.code == 0)
        refusal = run.err.removeprefix(f"beatlog: error: {log}: ").rstrip()
        refusals.add(refusal.split(" while ")[0])
    return refusals


def test_a_sample_nested_too_deep_is_one_line(beatlog: Beatlog, tmp_path: Path) -> None:
    def log_of(path: Path, deep: msgspec.Raw) -> Path:
        return one_cycle_log(path, cycle(samples=[["sonar", 0, deep]]), samples_logged=True)

    refusals = refusals_across_nestings(beatlog, tmp_path, log_of)

    assert "a sample of cycle 0 is nested too deep" in refusals
    assert refusals <= {"", "a sample of cycle 0 is nested too deep", READER_REFUSES}


@pytest.mark.parametrize("suffix", [".mcap", ".parquet", ".csv"])
def test_a_msgpack_extension_in_a_cycle_is_damage_in_one_line(
    beatlog: Beatlog, tmp_path: Path, suffix: str
) -> None:
    foreign = msgspec.msgpack.Ext(1, b"xx")
    log = one_cycle_log(tmp_path / "ext.beatlog", cycle(outputs={"speed": foreign}))
    output = tmp_path / f"ext{suffix}"

    run = beatlog("export", log, "-o", output)

    assert_error(run, f"{log}: damaged cycle 0: a msgpack extension (type 1), which no log holds")
    assert not output.exists()


def test_a_map_keyed_by_bytes_is_json_text_keyed_by_the_keys_json_text(tmp_path: Path) -> None:
    log = one_cycle_log(tmp_path / "keys.beatlog", cycle(outputs={"seen": {b"\x01": 2}}))

    export(log, tmp_path / "keys.mcap")

    (message,) = read_exported(tmp_path / "keys.mcap").messages["/outputs"]
    assert json.loads(message.value["outputs"]["seen"]) == {'"AQ=="': 2}  # the key's JSON text


def test_outputs_nested_too_deep_for_json_are_one_line(beatlog: Beatlog, tmp_path: Path) -> None:
    def log_of(path: Path, deep: msgspec.Raw) -> Path:
        return one_cycle_log(path, cycle(outputs={"plan": deep}))

    refusals = refusals_across_nestings(beatlog, tmp_path, log_of)

    assert "cycle 0 cannot be written as JSON: nested too deep" in refusals
    assert refusals <= {"", "cycle 0 cannot be written as JSON: nested too deep", READER_REFUSES}


def test_a_log_of_array_draws_exports_without_numpy(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_scatter(tmp_path / "arrays.beatlog", cycles=30)
    monkeypatch.setitem(sys.modules, "numpy", None)

    export(log, tmp_path / "arrays.mcap")
    export(log, tmp_path / "arrays.parquet")

    messages = read_exported(tmp_path / "arrays.mcap").messages["/random_numbers"]
    draws = [draw for message in messages for draw in message.value["draws"]]
    assert [(draw["kind"], json.loads(draw["params"])) for draw in draws] == [
        ("uniform_array", [0.0, 1.0, [2, 2]])
    ] * 6
    table = pq.read_table(tmp_path / "arrays.parquet")
    assert table.column("draws").to_pylist() == [1 if t % 5 == 0 else 0 for t in range(30)]
