"""Export a session log for viewers and for analysis; only the log is read, no code runs
(unless a system is given to replay, for its first divergence).

**MCAP for Foxglove and Lichtblick.** A ``.beatlog`` is MCAP, but its msgpack payloads
are not an encoding those viewers decode. The export writes message encoding ``json``
and schema encoding ``jsonschema``, one schema per channel (behavior channels share
one), each message stamped with robot time in nanoseconds and sequence-numbered with
its cycle. Both viewers read a JSON schema with one parser (``parseJsonSchema`` in
their ``mcap-support`` package), which takes only an object with ``properties`` whose
every field has one ``type``: boolean, string (base64 with ``contentEncoding``),
number, integer, an object with its own ``properties`` or an array of one of those.
Every schema here keeps to that, so every field is a typed field in the viewers'
message paths and plots, and every message validates against its schema:

- ``/robot_state``: RS_t, every cycle, as the header's robot-state schema declares
  it, every ``$ref`` inlined: numbers, integers, booleans and strings (an enum of
  strings or integers is one too), nested structs as objects, lists of those as
  arrays. What the viewers cannot type (a map, tuple, union, a list of lists or of
  nullables, a type inside itself) is a string of its JSON text. A null is left out.
  A log whose header declares no object is typed from a read of its fields.
- ``/behaviors/<name>``: a behavior's state after cycle 0, then after each change,
  as a string: the state as it prints (``idle``), or its JSON text if it is no
  string (``3``, ``true``). Before its first change a behavior's state is the
  ``before`` of that change; a behavior that never changes in the log has no known
  state and shows ``null``.
- ``/state_changes``: one Foxglove ``foxglove.Log`` message per change (INFO,
  ``avoid: idle -> turning``, the behavior as ``name``), for the Log panel. The
  schema is Foxglove's except ``level``: an integer here, not a ``oneOf`` of the
  level constants, which Lichtblick's parser refuses in releases that predate its
  enum support.
- ``/outputs``: the outputs of every cycle, each output a field typed as a first read
  of the log finds it (number, integer, boolean or string); an output whose values
  are lists, maps or of mixed types is a string of JSON text.
- ``/random_numbers``: the draws of each cycle that drew any: actor and kind, value
  and params as JSON text (a numpy array draw is dtype, shape and base64 bytes).
- ``/heartbeat``: HB_t of every cycle.
- ``/divergence``: with a system, one message at its first divergence from the log
  (``behavior`` empty when it concerns none; expected and actual state changes as
  lists of behavior, before and after strings).

JSON holds no NaN or infinity, and a plot's number field cannot hold a string: a
float field that is NaN or ±inf is left out of that message (a gap in a plot) and
listed in the message's ``non_finite`` string array as ``path=value``
(``distance=NaN``, ``pose.x=Infinity``, ``outputs.speed=-Infinity``); an array of
numbers holding one is left out whole and listed with its text
(``ranges=[0.5,NaN]``). Inside JSON text they are the strings ``"NaN"``,
``"Infinity"`` and ``"-Infinity"``, and bytes are base64.

**Tables** (Parquet, which needs the ``export`` extra, or CSV): one row per cycle
with ``cycle``, ``time_ns``, ``heartbeat_ns``, one column per robot-state field
(``a.b`` for a nested struct's field), ``behavior.<name>`` (its state after the
cycle, as on the behavior channels), ``out.<name>`` and ``draws`` (how many random
numbers the cycle drew). A list or map in a cell is its JSON text, and so is every
value of a Parquet column whose values differ in type. Floats stay floats:
Parquet keeps NaN and ±inf, CSV writes ``nan``, ``inf`` and ``-inf``.
"""

from __future__ import annotations

import base64
import csv
import json
import math
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from enum import Enum, StrEnum
from pathlib import Path
from typing import Any, NamedTuple

import msgspec
from mcap.writer import Writer

from beatlog._version import __version__
from beatlog.errors import CorruptLogError, ExportError
from beatlog.log.format import (
    DECODE_ERRORS,
    EMPTY_LIST,
    Draw,
    SessionHeader,
    StateChangeRecord,
)
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.model.behavior import BehaviorState, System
from beatlog.replay.judge import replay
from beatlog.replay.verdict import Divergence, DivergenceKind, ReplayResult, StateChange

__all__ = ["ExportFormat", "ExportResult", "export"]


class ExportFormat(StrEnum):
    """What ``beatlog export`` writes."""

    MCAP = "mcap"
    """MCAP with JSON messages and JSON schemas, for Foxglove and Lichtblick."""
    PARQUET = "parquet"
    """One row per cycle in Parquet (needs pyarrow: ``pip install "beatlog[export]"``)."""
    CSV = "csv"
    """One row per cycle as comma-separated text."""


@dataclass(frozen=True)
class ExportResult:
    """What an export wrote."""

    log: Path
    output: Path
    format: ExportFormat
    cycles: int
    status: LogStatus
    """How the log ended; a truncated log is exported up to its last complete cycle."""
    replayed: bool
    """Whether a system was replayed for the divergence."""
    divergence: Divergence | None
    """The replay's first divergence, when a system was replayed and it diverged."""
    url: str | None = None
    """The URL of the log, when it lay behind one: ``log`` is then the copy exported,
    which is gone."""

    @property
    def log_name(self) -> str:
        """The log as messages name it: its URL, or its path."""
        return str(self.log) if self.url is None else self.url

    def describe(self) -> str:
        """One line for people: what was written, how the log ended, what replay found."""
        line = f"exported {self.cycles} cycles of {self.log_name} to {self.output} ({self.format})"
        if not self.status.complete:
            line += f"; the log is {self.status.describe()}"
        if self.divergence is not None:
            line += f"; first divergence at cycle {self.divergence.cycle} ({self.divergence.kind})"
        elif self.replayed:
            line += "; the replay passed"
        return line


def export(
    log: str | Path,
    output: str | Path,
    *,
    format: ExportFormat | str = ExportFormat.MCAP,
    system: System | str | None = None,
) -> ExportResult:
    """Write ``log`` to ``output`` in ``format``; with ``system`` (MCAP only), replay the
    log against it and add its first divergence.

    The output is written next to its final place and moved there when complete, so
    an export that fails (a damaged log, a full disk) leaves no partial file.

    :raises beatlog.errors.LogError: the log cannot be read (or does not fit ``system``).
    :raises beatlog.errors.ExportError: the output cannot be written, Parquet is asked
        for without pyarrow, or a system is given for a table.
    """
    log, output = Path(log), Path(output)
    try:
        chosen = ExportFormat(format)
    except ValueError:
        choices = ", ".join(ExportFormat)
        raise ExportError(f"cannot export as {format!r}; choose one of {choices}") from None
    if system is not None and chosen is not ExportFormat.MCAP:
        raise ExportError(f"a replay's divergence is exported to MCAP only, not {chosen}")
    if chosen is ExportFormat.PARQUET:
        _pyarrow()
    if output.exists() and log.exists() and output.samefile(log):
        raise ExportError(f"{output}: is the session log being exported; name another file")
    replayed = (
        None
        if system is None
        else replay(log, system, allow_truncated=True, allow_empty=True, explain=False)
    )
    first = _first_read(log)
    with SessionLogReader(log) as reader, _replacing(output) as part:
        session = _Session(log, reader.header, _decoded_cycles(reader), first)
        if chosen is ExportFormat.MCAP:
            _write_mcap(part, session, replayed)
        else:
            _write_table(part, session, chosen)
        status = reader.status
    return ExportResult(
        log=log,
        output=output,
        format=chosen,
        cycles=status.cycles,
        status=status,
        replayed=replayed is not None,
        divergence=None if replayed is None else replayed.divergence,
    )


class _Cycle(NamedTuple):
    """One cycle of the log, decoded, with behaviors and actors by name."""

    number: int
    time_ns: int
    heartbeat_ns: int
    robot_state: dict[str, Any]
    changes: list[StateChange]
    draws: list[tuple[str, Draw]]
    outputs: dict[str, Any]


class _FirstRead(NamedTuple):
    """What a first pass over the log finds."""

    initial: Mapping[str, BehaviorState]
    """Each catalogue behavior's state at the start: the ``before`` of its first change
    (None for a behavior that never changes in the log)."""
    output_types: Mapping[str, str | None]
    """Each output's JSON-schema type over the whole log (see ``_add_types``)."""


class _Session(NamedTuple):
    """What the writers read: the log, its header, its cycles decoded one by one, and
    what a first read of the log found."""

    log: Path
    header: SessionHeader
    cycles: Iterator[_Cycle]
    first: _FirstRead


def _decoded_cycles(reader: SessionLogReader) -> Iterator[_Cycle]:
    names = reader.header.behaviors
    decode_map = msgspec.msgpack.Decoder(dict[str, Any]).decode
    decode_changes = msgspec.msgpack.Decoder(list[StateChangeRecord]).decode
    decode_draws = msgspec.msgpack.Decoder(list[Draw]).decode
    time_ns = 0
    for number, record in enumerate(reader.cycles()):
        time_ns += record.heartbeat_ns
        try:
            state = decode_map(record.robot_state)
            changes = (
                [] if record.state_changes == EMPTY_LIST else decode_changes(record.state_changes)
            )
            draws = (
                [] if record.random_numbers == EMPTY_LIST else decode_draws(record.random_numbers)
            )
            outputs = decode_map(record.outputs)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(reader.path, f"damaged cycle {number}: {exc}") from None
        yield _Cycle(
            number,
            time_ns,
            record.heartbeat_ns,
            state,
            [StateChange(_name(names, index), before, after) for index, before, after in changes],
            [(_name(names, draw.actor), draw) for draw in draws],
            outputs,
        )


def _name(catalogue: Sequence[str], index: int) -> str:
    if index < 0:
        return "system"
    return catalogue[index] if index < len(catalogue) else f"#{index}"


def _first_read(log: Path) -> _FirstRead:
    with SessionLogReader(log) as reader:
        states: dict[str, BehaviorState] = reader.header.initial_states_by_name()
        output_types: dict[str, str | None] = {}
        for cycle in _decoded_cycles(reader):
            for change in cycle.changes:
                states.setdefault(change.behavior, change.before)
            _add_types(output_types, cycle.outputs)
        initial = {name: states.get(name) for name in reader.header.behaviors}
        return _FirstRead(initial, output_types)


def _states_after(states: dict[str, BehaviorState], changes: Sequence[StateChange]) -> None:
    """Apply a cycle's changes of catalogue behaviors to ``states``."""
    for change in changes:
        if change.behavior in states:
            states[change.behavior] = change.after


@contextmanager
def _replacing(output: Path) -> Iterator[Path]:
    """A file to write next to ``output``, moved over it when the block completes."""
    part = output.with_name(f".{output.name}.part")
    try:
        yield part
        part.replace(output)
    except OSError as exc:
        raise ExportError(f"{output}: cannot write: {exc.strerror or exc}") from None
    finally:
        part.unlink(missing_ok=True)


# JSON


def _jsonable(value: Any) -> Any:
    """``value`` with NaN and ±inf as strings and map keys as strings; JSON encodes the
    rest (bytes as base64)."""
    if isinstance(value, float):
        if math.isfinite(value):
            return value
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, dict):
        return {
            key if isinstance(key, str) else json.dumps(_jsonable(key)): _jsonable(item)
            for key, item in value.items()
        }
    if isinstance(value, list | tuple):
        return [_jsonable(item) for item in value]
    return value


_JSON = msgspec.json.Encoder()


def _json_text(value: Any, log: Path, where: str) -> bytes:
    try:
        return _JSON.encode(_jsonable(value))
    except (TypeError, msgspec.EncodeError, RecursionError) as exc:
        raise CorruptLogError(log, f"{where} cannot be written as JSON: {exc}") from None


def _state_text(state: BehaviorState) -> str:
    """A behavior state as a viewer shows it: a string as it is, anything else as JSON."""
    return state if isinstance(state, str) else json.dumps(state)


# MCAP: what a field is for the viewers


class _Kind(Enum):
    NUMBER = "a JSON number; NaN and ±inf are left out and listed in non_finite"
    PLAIN = "an integer, boolean or string, written as it is"
    OBJECT = "an object with its own fields"
    ARRAY = "an array of numbers, integers, booleans, strings or objects"
    JSON = "a string holding the value's JSON text"


class _Field(NamedTuple):
    """A field as the viewers get it: its JSON schema and how a value is written."""

    schema: dict[str, Any]
    kind: _Kind
    fields: Mapping[str, _Field] = {}
    """An object's fields."""
    items: _Field | None = None
    """An array's items."""


_NON_FINITE = "non_finite"
_NON_FINITE_SCHEMA = {
    "type": "array",
    "items": {"type": "string"},
    "description": "The fields left out of this message because their value is NaN or "
    "infinite, as path=value: distance=NaN, outputs.speed=-Infinity, ranges=[0.5,NaN].",
}
_JSON_TEXT = {
    "type": "string",
    "description": 'JSON text of the value: NaN and ±inf as the strings "NaN", "Infinity" '
    'and "-Infinity", bytes as base64.',
}
_BY_TYPE = {
    "number": _Field({"type": "number"}, _Kind.NUMBER),
    "integer": _Field({"type": "integer"}, _Kind.PLAIN),
    "boolean": _Field({"type": "boolean"}, _Kind.PLAIN),
    "string": _Field({"type": "string"}, _Kind.PLAIN),
    "json": _Field(_JSON_TEXT, _Kind.JSON),
}
_ARRAY_ITEMS = frozenset({_Kind.NUMBER, _Kind.PLAIN, _Kind.OBJECT})
_GAP = object()
"""What a value left out of its message is written as."""


def _written(field: _Field, value: Any, path: str, non_finite: list[str]) -> Any:
    """``value`` as ``field`` declares it, or ``_GAP`` for a null, NaN or ±inf (listed in
    ``non_finite`` as ``path=value``; an array of numbers holding one is left out whole)."""
    if value is None:
        return _GAP
    kind = field.kind
    if kind is _Kind.NUMBER:
        if isinstance(value, float) and not math.isfinite(value):
            non_finite.append(f"{path}={json.dumps(value)}")
            return _GAP
        return value
    if kind is _Kind.OBJECT:
        return _written_object(field.fields, value, f"{path}.", non_finite)
    items = field.items
    if items is not None:  # an array
        if items.kind is _Kind.NUMBER:
            if not all(math.isfinite(item) for item in value):
                non_finite.append(f"{path}={json.dumps(value, separators=(',', ':'))}")
                return _GAP
            return value
        return [_written(items, item, f"{path}[{i}]", non_finite) for i, item in enumerate(value)]
    if kind is _Kind.JSON:
        return _JSON.encode(_jsonable(value)).decode()
    return value


def _written_object(
    fields: Mapping[str, _Field], value: Mapping[str, Any], prefix: str, non_finite: list[str]
) -> dict[str, Any]:
    """The declared fields of ``value`` (a field the schema lacks is left out)."""
    written = {}
    for name, field in fields.items():
        if name in value:
            item = _written(field, value[name], f"{prefix}{name}", non_finite)
            if item is not _GAP:
                written[name] = item
    return written


def _type_of(value: Any) -> str:
    """The JSON-schema type of a value read from the log (``json`` for lists, maps, bytes)."""
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "number"
    return "string" if isinstance(value, str) else "json"


def _add_types(types: dict[str, str | None], values: Mapping[str, Any]) -> None:
    """Merge the types of ``values`` into ``types``: integers and floats make a number,
    any other mix is JSON text; a field that is always null stays None."""
    for name, value in values.items():
        seen = types.get(name)
        if value is None:
            types.setdefault(name, None)
        elif seen is None:
            types[name] = _type_of(value)
        elif seen != "json":
            kind = _type_of(value)
            if kind != seen:
                types[name] = "number" if {kind, seen} == {"integer", "number"} else "json"


def _typed_object(types: Mapping[str, str | None]) -> _Field:
    """An object of the fields a first read of the log found, typed as it found them."""
    fields = {name: _BY_TYPE[kind or "json"] for name, kind in types.items()}
    properties = {name: field.schema for name, field in fields.items()}
    return _Field({"type": "object", "properties": properties}, _Kind.OBJECT, fields)


_MAX_SCHEMA_NODES = 100_000
"""A robot-state schema inlined beyond this many nodes is refused (a hostile header
could otherwise expand exponentially)."""


def _declared_object(schema: Mapping[str, Any], log: Path) -> _Field | None:
    """The header's robot-state schema as the viewers take it (None if it describes no
    object with properties): every ``$ref`` to ``#/$defs/...`` inlined; a number,
    integer, boolean or string as that type (an enum of strings or of integers too, a
    nullable one too: a null is left out); an object with properties and an array of
    those with their own schemas; anything else (a map, tuple, union, an array of
    arrays or of nullables, a type within itself) as JSON text."""
    definitions = schema.get("$defs")
    defs = definitions if isinstance(definitions, dict) else {}
    nodes = 0

    def field(node: Any, within: tuple[str, ...], nullable: bool) -> _Field:
        nonlocal nodes
        nodes += 1
        if nodes > _MAX_SCHEMA_NODES:
            raise CorruptLogError(
                log, f"the robot-state schema inlines to more than {_MAX_SCHEMA_NODES} nodes"
            )
        if not isinstance(node, dict):
            return _BY_TYPE["json"]
        reference = node.get("$ref")
        if reference is not None:
            name = reference.removeprefix("#/$defs/") if isinstance(reference, str) else ""
            if name == reference or name not in defs:
                raise CorruptLogError(
                    log, f"the robot-state schema refers to {reference!r}, which it lacks"
                )
            target = defs[name]
            if name in within or not isinstance(target, dict):
                return _BY_TYPE["json"]
            rest = {key: value for key, value in node.items() if key != "$ref"}
            return field({**rest, **target}, (*within, name), nullable)
        kind = node.get("type")
        alternatives = node.get("anyOf", node.get("oneOf"))
        if isinstance(alternatives, list):
            others = [option for option in alternatives if option != {"type": "null"}]
            if not (nullable and len(others) == 1 == len(alternatives) - 1):
                return _BY_TYPE["json"]
            return field(others[0], within, nullable=False)
        if isinstance(kind, list):
            others = [option for option in kind if option != "null"]
            kind = others[0] if nullable and len(others) == 1 == len(kind) - 1 else "json"
        enum = node.get("enum")
        if kind is None and isinstance(enum, list) and enum:
            kinds = {_type_of(value) for value in enum}
            kind = kinds.pop() if len(kinds) == 1 else "json"
        properties = node.get("properties")
        items = node.get("items")
        if kind == "object" and isinstance(properties, dict):
            fields = {
                name: field(value, within, nullable=True) for name, value in properties.items()
            }
            declared = {name: value.schema for name, value in fields.items()}
            return _Field({"type": "object", "properties": declared}, _Kind.OBJECT, fields)
        if kind == "array" and isinstance(items, dict) and "prefixItems" not in node:
            item = field(items, within, nullable=False)
            if item.kind in _ARRAY_ITEMS:
                return _Field({"type": "array", "items": item.schema}, _Kind.ARRAY, items=item)
            return _BY_TYPE["json"]
        if kind == "string" and node.get("contentEncoding") == "base64":
            return _Field({"type": "string", "contentEncoding": "base64"}, _Kind.PLAIN)
        return _BY_TYPE.get(kind if isinstance(kind, str) else "json", _BY_TYPE["json"])

    try:
        declared = field(dict(schema), (), nullable=False)
    except RecursionError:
        raise CorruptLogError(log, "the robot-state schema is nested too deep") from None
    return declared if declared.kind is _Kind.OBJECT else None


# MCAP: schemas

_DIALECT = "https://json-schema.org/draft/2020-12/schema"
_CYCLE = {"type": "integer", "minimum": 0, "description": "The cycle (heartbeat) t."}
_STATE = {
    "type": "string",
    "description": "The state as it prints (idle), or its JSON text if it is no string "
    "(3, true, null).",
}
_CHANGE = {
    "type": "object",
    "properties": {"behavior": {"type": "string"}, "before": _STATE, "after": _STATE},
    "required": ["behavior", "before", "after"],
    "additionalProperties": False,
}


def _record_schema(
    title: str, description: str, optional: Sequence[str] = (), **properties: Mapping[str, Any]
) -> dict[str, Any]:
    return {
        "$schema": _DIALECT,
        "title": title,
        "description": description,
        "type": "object",
        "properties": {"cycle": _CYCLE, **properties},
        "required": ["cycle", *(name for name in properties if name not in optional)],
        "additionalProperties": False,
    }


_HEARTBEAT_SCHEMA = _record_schema(
    "beatlog.Heartbeat",
    "The heartbeat interval HB_t that ended this cycle.",
    interval_ns={"type": "integer", "minimum": 0},
    interval_ms={"type": "number", "minimum": 0},
)
_BEHAVIOR_SCHEMA = _record_schema(
    "beatlog.BehaviorState",
    'A behavior\'s state after this cycle; "null" when the log never shows it (it never changes).',
    state=_STATE,
)
_RANDOM_SCHEMA = _record_schema(
    "beatlog.RandomNumbers",
    "The random numbers drawn in this cycle, in draw order (RN_t).",
    draws={
        "type": "array",
        "items": {
            "type": "object",
            "properties": {
                "actor": {"type": "string", "description": "The behavior, or 'system'."},
                "kind": {"type": "string"},
                "value": _JSON_TEXT,
                "params": _JSON_TEXT,
            },
            "required": ["actor", "kind", "value", "params"],
            "additionalProperties": False,
        },
    },
)
_DIVERGENCE_SCHEMA = _record_schema(
    "beatlog.Divergence",
    "The first cycle where replaying the log against a system differed from it.",
    kind={"type": "string", "enum": list(DivergenceKind)},
    message={"type": "string"},
    behavior={"type": "string", "description": "The behavior it concerns; empty if none."},
    expected={"type": "array", "items": _CHANGE},
    actual={"type": "array", "items": _CHANGE},
    reproduce={"type": "string"},
)
# Foxglove's well-known foxglove.Log, as published in foxglove/schemas
# (schemas/jsonschema/Log.json), except its level: there a oneOf of the level
# constants, which Lichtblick's parser rejects in releases that predate its enum
# support, here an integer. The name makes Foxglove's Log panel show it.
_FOXGLOVE_LOG_SCHEMA = {
    "title": "Log",
    "description": "A log message",
    "type": "object",
    "properties": {
        "timestamp": {
            "type": "object",
            "title": "Time",
            "properties": {
                "sec": {"type": "integer", "minimum": 0},
                "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999},
            },
            "description": "Timestamp of log message",
        },
        "level": {
            "type": "integer",
            "minimum": 0,
            "maximum": 5,
            "title": "LogLevel: Log level",
            "description": "Log level: 0 UNKNOWN, 1 DEBUG, 2 INFO, 3 WARNING, 4 ERROR, 5 FATAL",
        },
        "message": {"type": "string", "description": "Log message"},
        "name": {"type": "string", "description": "Process or node name"},
        "file": {"type": "string", "description": "Filename"},
        "line": {"type": "integer", "minimum": 0, "description": "Line number in the file"},
    },
}
_LOG_INFO = 2


def _robot_state_schema(title: str, robot_state: _Field) -> dict[str, Any]:
    return {
        "$schema": _DIALECT,
        "title": title,
        **robot_state.schema,
        "properties": {**robot_state.schema["properties"], _NON_FINITE: _NON_FINITE_SCHEMA},
    }


def _outputs_schema(outputs: _Field) -> dict[str, Any]:
    return _record_schema(
        "beatlog.Outputs",
        "What the behaviors output in this cycle, e.g. motor commands, typed as a first "
        "read of the log found them (lists, maps and mixed types as JSON text).",
        optional=[_NON_FINITE],
        outputs=outputs.schema,
        non_finite=_NON_FINITE_SCHEMA,
    )


# MCAP: messages


class _McapChannels:
    """Registers the export's schemas and channels and writes JSON messages to them."""

    def __init__(self, writer: Writer, log: Path) -> None:
        self._writer = writer
        self._log = log
        self._schemas: dict[str, int] = {}

    def add(self, topic: str, name: str, schema: Mapping[str, Any]) -> int:
        if name not in self._schemas:
            data = _json_text(schema, self._log, f"the schema of {topic}")
            self._schemas[name] = self._writer.register_schema(name, "jsonschema", data)
        return int(self._writer.register_channel(topic, "json", self._schemas[name]))

    def write(self, channel: int, cycle: _Cycle, message: Any, what: str) -> None:
        """Write ``message`` stamped with the cycle's robot time and numbered with it."""
        data = _json_text(message, self._log, f"the {what} of cycle {cycle.number}")
        time_ns = cycle.time_ns
        self._writer.add_message(channel, time_ns, data, time_ns, sequence=cycle.number)


def _robot_state_field(session: _Session) -> _Field:
    """The robot state's fields: as the header declares them, else as a read of the log
    finds them."""
    declared = _declared_object(session.header.robot_state_schema, session.log)
    if declared is None:
        types: dict[str, str | None] = {}
        with SessionLogReader(session.log) as reader:
            for cycle in _decoded_cycles(reader):
                _add_types(types, cycle.robot_state)
        declared = _typed_object(types)
    if _NON_FINITE in declared.fields:
        raise ExportError(
            f"{session.log}: robot-state field {_NON_FINITE!r} has the name of the field "
            "that lists NaN and infinite values; export as a table instead"
        )
    return declared


def _write_mcap(part: Path, session: _Session, replayed: ReplayResult | None) -> None:
    log, header = session.log, session.header
    robot_state_field = _robot_state_field(session)
    outputs_field = _typed_object(session.first.output_types)
    with part.open("wb") as file:
        writer = Writer(file)
        writer.start(profile="", library=f"beatlog {__version__}")
        writer.add_metadata(
            "beatlog",
            {
                "log": log.name,
                "format_version": str(header.format_version),
                "robot_id": header.robot_id,
                "software_version": header.software_version,
                "system": header.system,
                "robot_state_type": header.robot_state_type,
                "period_ns": str(header.period_ns),
                "start_time_ns": str(header.start_time_ns),
            },
        )
        channels = _McapChannels(writer, log)
        robot_state_name = header.robot_state_type or "beatlog.RobotState"
        robot_state = channels.add(
            "/robot_state",
            robot_state_name,
            _robot_state_schema(robot_state_name, robot_state_field),
        )
        behaviors = {
            name: channels.add(f"/behaviors/{name}", "beatlog.BehaviorState", _BEHAVIOR_SCHEMA)
            for name in header.behaviors
        }
        state_changes = channels.add("/state_changes", "foxglove.Log", _FOXGLOVE_LOG_SCHEMA)
        outputs = channels.add("/outputs", "beatlog.Outputs", _outputs_schema(outputs_field))
        random_numbers = channels.add("/random_numbers", "beatlog.RandomNumbers", _RANDOM_SCHEMA)
        heartbeat = channels.add("/heartbeat", "beatlog.Heartbeat", _HEARTBEAT_SCHEMA)
        divergence = None if replayed is None else replayed.divergence
        found = (
            None
            if divergence is None
            else channels.add("/divergence", "beatlog.Divergence", _DIVERGENCE_SCHEMA)
        )
        states = dict(session.first.initial)
        write = channels.write
        for cycle in session.cycles:
            number = cycle.number
            non_finite: list[str] = []
            state = _written_object(robot_state_field.fields, cycle.robot_state, "", non_finite)
            write(robot_state, cycle, _with_non_finite(state, non_finite), "robot state")
            interval_ns = cycle.heartbeat_ns
            heartbeat_message = {
                "cycle": number,
                "interval_ns": interval_ns,
                "interval_ms": interval_ns / 1e6,
            }
            write(heartbeat, cycle, heartbeat_message, "heartbeat")
            _states_after(states, cycle.changes)
            if number == 0:
                for name, channel in behaviors.items():
                    message = {"cycle": 0, "state": _state_text(states[name])}
                    write(channel, cycle, message, "behavior state")
            for change in cycle.changes:
                lane = behaviors.get(change.behavior)
                if number > 0 and lane is not None:
                    message = {"cycle": number, "state": _state_text(change.after)}
                    write(lane, cycle, message, "behavior state")
                write(state_changes, cycle, _log_message(cycle.time_ns, change), "state change")
            non_finite = []
            written = _written_object(outputs_field.fields, cycle.outputs, "outputs.", non_finite)
            message = _with_non_finite({"cycle": number, "outputs": written}, non_finite)
            write(outputs, cycle, message, "outputs")
            if cycle.draws:
                write(random_numbers, cycle, _draws_message(cycle, log), "random numbers")
            if found is not None and divergence is not None and divergence.cycle == number:
                message = _divergence_message(divergence, replayed.reproduce if replayed else "")
                write(found, cycle, message, "divergence")
        writer.finish()  # type: ignore[no-untyped-call]


def _with_non_finite(message: dict[str, Any], non_finite: list[str]) -> dict[str, Any]:
    if non_finite:
        message[_NON_FINITE] = non_finite
    return message


def _log_message(time_ns: int, change: StateChange) -> dict[str, Any]:
    """A behavior state change as a ``foxglove.Log`` message."""
    seconds, nanoseconds = divmod(time_ns, 1_000_000_000)
    return {
        "timestamp": {"sec": seconds, "nsec": nanoseconds},
        "level": _LOG_INFO,
        "message": f"{change.behavior}: {change.before} -> {change.after}",
        "name": change.behavior,
        "file": "",
        "line": 0,
    }


def _draws_message(cycle: _Cycle, log: Path) -> dict[str, Any]:
    where = f"a random number of cycle {cycle.number}"
    return {
        "cycle": cycle.number,
        "draws": [
            {
                "actor": actor,
                "kind": draw.kind,
                "value": _json_text(draw.value, log, where).decode(),
                "params": _json_text(draw.params, log, where).decode(),
            }
            for actor, draw in cycle.draws
        ],
    }


def _divergence_message(divergence: Divergence, reproduce: str) -> dict[str, Any]:
    def changes(which: Sequence[StateChange]) -> list[dict[str, str]]:
        return [
            {
                "behavior": change.behavior,
                "before": _state_text(change.before),
                "after": _state_text(change.after),
            }
            for change in which
        ]

    return {
        "cycle": divergence.cycle,
        "kind": divergence.kind.value,
        "message": divergence.message,
        "behavior": divergence.behavior or "",
        "expected": changes(divergence.expected),
        "actual": changes(divergence.actual),
        "reproduce": reproduce,
    }


# Tables

_FIRST_COLUMNS = ("cycle", "time_ns", "heartbeat_ns")
_DRAWS_COLUMN = "draws"


def _write_table(part: Path, session: _Session, chosen: ExportFormat) -> None:
    log = session.log
    states = dict(session.first.initial)
    state_columns: dict[str, None] = {}
    output_columns: dict[str, None] = {}
    behavior_columns = {name: f"behavior.{name}" for name in session.header.behaviors}
    rows: list[dict[str, Any]] = []
    for cycle in session.cycles:
        _states_after(states, cycle.changes)
        where = f"cycle {cycle.number}"
        fields = _flatten(cycle.robot_state, "", log, where)
        outputs = {f"out.{name}": _cell(value, log, where) for name, value in cycle.outputs.items()}
        state_columns.update(dict.fromkeys(fields))
        output_columns.update(dict.fromkeys(outputs))
        rows.append(
            {
                "cycle": cycle.number,
                "time_ns": cycle.time_ns,
                "heartbeat_ns": cycle.heartbeat_ns,
                **fields,
                **{column: states[name] for name, column in behavior_columns.items()},
                **outputs,
                _DRAWS_COLUMN: len(cycle.draws),
            }
        )
    others = [*_FIRST_COLUMNS, *behavior_columns.values(), *output_columns, _DRAWS_COLUMN]
    clash = next((name for name in state_columns if name in others), None)
    if clash is not None:
        raise ExportError(
            f"{log}: robot-state field {clash!r} has the name of another column; "
            "export as MCAP instead"
        )
    columns = [*_FIRST_COLUMNS, *state_columns, *others[len(_FIRST_COLUMNS) :]]
    if chosen is ExportFormat.CSV:
        with part.open("w", encoding="utf-8", newline="") as file:
            table = csv.writer(file)
            table.writerow(columns)
            table.writerows([row.get(column) for column in columns] for row in rows)
        return
    pa, parquet = _pyarrow()
    arrays = []
    for column in columns:
        values = [row.get(column) for row in rows]
        try:
            arrays.append(pa.array(values))
        except pa.ArrowException:  # mixed types: every cell but a missing one as JSON text
            texts = [None if v is None else _JSON.encode(_jsonable(v)).decode() for v in values]
            arrays.append(pa.array(texts))
    parquet.write_table(pa.Table.from_arrays(arrays, names=columns), part)


def _pyarrow() -> tuple[Any, Any]:
    """pyarrow and its Parquet module, from the optional ``export`` extra."""
    try:
        import pyarrow  # noqa: PLC0415 - optional
        import pyarrow.parquet  # noqa: PLC0415
    except ModuleNotFoundError:
        raise ExportError('Parquet export needs pyarrow (pip install "beatlog[export]")') from None
    return pyarrow, pyarrow.parquet


def _flatten(value: Mapping[Any, Any], prefix: str, log: Path, where: str) -> dict[str, Any]:
    """A robot state's fields as columns, a nested struct's fields as ``a.b``."""
    columns: dict[str, Any] = {}
    for key, item in value.items():
        name = f"{prefix}{key}"
        if isinstance(item, dict):
            columns.update(_flatten(item, f"{name}.", log, where))
        else:
            columns[name] = _cell(item, log, where)
    return columns


def _cell(value: Any, log: Path, where: str) -> Any:
    """A table cell: a number, string, bool or None as it is; bytes as base64; a list
    or map as its JSON text."""
    if isinstance(value, bytes):
        return base64.b64encode(value).decode()
    if isinstance(value, list | dict):
        return _json_text(value, log, where).decode()
    return value
