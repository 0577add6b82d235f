"""Export a session log for viewers and for analysis; only the log is read, no code runs
(unless a system is given to replay, for its first divergence).

**MCAP for Foxglove and Lichtblick.** A ``.beatlog`` is MCAP, but its msgpack payloads
are not an encoding those viewers decode. The export writes message encoding ``json``
and schema encoding ``jsonschema``, one schema per channel (behavior channels share
one), each message stamped with robot time in nanoseconds and sequence-numbered with
its cycle:

- ``/robot_state``: RS_t, every cycle; its schema is the header's robot-state schema
  with every ``$ref`` inlined (a type that contains itself is left open).
- ``/behaviors/<name>``: a behavior's state after cycle 0, then after each change.
  Before its first change a behavior's state is the ``before`` of that change; a
  behavior that never changes in the log has no known state and shows ``null``.
- ``/state_changes``: one Foxglove ``foxglove.Log`` message per change (INFO,
  ``avoid: idle -> turning``, the behavior as ``name``), for the Log panel.
- ``/outputs``: the outputs of every cycle.
- ``/random_numbers``: the draws of each cycle that drew any (actor, kind, value, params).
- ``/heartbeat``: HB_t of every cycle.
- ``/divergence``: with a system, one message at its first divergence from the log.

JSON holds no NaN or infinity, so a float that is one is written as the string
``"NaN"``, ``"Infinity"`` or ``"-Infinity"``, and every number in a schema is declared
``"type": ["number", "string"]``; bytes (numpy array draws) are base64 strings.

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
from enum import StrEnum
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

    def describe(self) -> str:
        """One line for people: what was written, how the log ended, what replay found."""
        line = f"exported {self.cycles} cycles of {self.log} to {self.output} ({self.format})"
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
    replayed = None if system is None else replay(log, system, allow_truncated=True, explain=False)
    initial = _states_before_changes(log)
    with SessionLogReader(log) as reader, _replacing(output) as part:
        session = _Session(log, reader.header, _decoded_cycles(reader), initial)
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


class _Session(NamedTuple):
    """What the writers read: the log, its header, its cycles decoded one by one, and
    each catalogue behavior's state before its first change."""

    log: Path
    header: SessionHeader
    cycles: Iterator[_Cycle]
    initial: Mapping[str, BehaviorState]


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


def _states_before_changes(log: Path) -> dict[str, BehaviorState]:
    """Each catalogue behavior's state at the start: the ``before`` of its first change
    (None for a behavior that never changes in the log). A first pass over the log."""
    with SessionLogReader(log) as reader:
        states: dict[str, BehaviorState] = {}
        for cycle in _decoded_cycles(reader):
            for change in cycle.changes:
                states.setdefault(change.behavior, change.before)
        return {name: states.get(name) for name in reader.header.behaviors}


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


# MCAP: schemas

_DIALECT = "https://json-schema.org/draft/2020-12/schema"
_CYCLE = {"type": "integer", "minimum": 0, "description": "The cycle (heartbeat) t."}
_ANY = {
    "description": 'Any JSON value; a NaN or infinite float is "NaN", "Infinity" or '
    '"-Infinity", bytes are base64.'
}
_BEHAVIOR_STATE = {"type": ["string", "integer", "boolean", "null"]}
_CHANGE = {
    "type": "object",
    "properties": {
        "behavior": {"type": "string"},
        "before": _BEHAVIOR_STATE,
        "after": _BEHAVIOR_STATE,
    },
    "required": ["behavior", "before", "after"],
    "additionalProperties": False,
}


def _record_schema(title: str, description: str, **properties: Mapping[str, Any]) -> dict[str, Any]:
    return {
        "$schema": _DIALECT,
        "title": title,
        "description": description,
        "type": "object",
        "properties": {"cycle": _CYCLE, **properties},
        "required": ["cycle", *properties],
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
    "A behavior's state after this cycle; null when the log never shows it (it never changes).",
    state=_BEHAVIOR_STATE,
)
_OUTPUTS_SCHEMA = _record_schema(
    "beatlog.Outputs",
    "What the behaviors output in this cycle, e.g. motor commands.",
    outputs={"type": "object", "additionalProperties": _ANY},
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
                "value": _ANY,
                "params": {"type": "array", "items": _ANY},
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
    behavior={"type": ["string", "null"]},
    expected={"type": "array", "items": _CHANGE},
    actual={"type": "array", "items": _CHANGE},
    reproduce={"type": "string"},
)
# Foxglove's well-known foxglove.Log, as published in foxglove/schemas
# (schemas/jsonschema/Log.json); the name makes Foxglove's Log panel show it.
_FOXGLOVE_LOG_SCHEMA = {
    "$comment": "Generated from Log by @foxglove/message-schemas",
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
            "title": "LogLevel: Log level",
            "description": "Log level",
            "oneOf": [
                {"title": "UNKNOWN", "const": 0},
                {"title": "DEBUG", "const": 1},
                {"title": "INFO", "const": 2},
                {"title": "WARNING", "const": 3},
                {"title": "ERROR", "const": 4},
                {"title": "FATAL", "const": 5},
            ],
        },
        "message": {"type": "string", "description": "Log message"},
        "name": {"type": "string", "description": "Process or node name"},
        "file": {"type": "string", "description": "Filename"},
        "line": {"type": "integer", "minimum": 0, "description": "Line number in the file"},
    },
}
_LOG_INFO = 2

_MAX_SCHEMA_NODES = 100_000
"""A robot-state schema inlined beyond this many nodes is refused (a hostile header
could otherwise expand exponentially)."""
_SUBSCHEMA = frozenset(
    {
        "items",
        "additionalProperties",
        "not",
        "contains",
        "if",
        "then",
        "else",
        "propertyNames",
        "unevaluatedItems",
        "unevaluatedProperties",
    }
)
_SUBSCHEMA_LISTS = frozenset({"prefixItems", "anyOf", "oneOf", "allOf"})
_SUBSCHEMA_MAPS = frozenset({"properties", "patternProperties", "dependentSchemas"})


def _viewer_schema(schema: Mapping[str, Any], log: Path) -> dict[str, Any]:
    """The header's robot-state schema made self-contained for viewers: every
    ``$ref`` to ``#/$defs/...`` inlined (a type within itself becomes any value),
    ``$defs`` dropped, and every number allowed to be one of the strings that stand for
    NaN and ±inf."""
    definitions = schema.get("$defs")
    defs = definitions if isinstance(definitions, dict) else {}
    nodes = 0

    def inline(node: Any, within: tuple[str, ...]) -> Any:
        nonlocal nodes
        nodes += 1
        if nodes > _MAX_SCHEMA_NODES:
            raise CorruptLogError(
                log, f"the robot-state schema inlines to more than {_MAX_SCHEMA_NODES} nodes"
            )
        if not isinstance(node, dict):
            return node
        resolved: dict[str, Any] = {}
        reference = node.get("$ref")
        if reference is not None:
            name = reference.removeprefix("#/$defs/") if isinstance(reference, str) else ""
            if name == reference or name not in defs:
                raise CorruptLogError(
                    log, f"the robot-state schema refers to {reference!r}, which it lacks"
                )
            if name in within:
                return dict(_ANY)
            resolved.update(inline(defs[name], (*within, name)))
        for key, value in node.items():
            if key in ("$ref", "$defs"):
                continue
            if key in _SUBSCHEMA:
                resolved[key] = inline(value, within)
            elif key in _SUBSCHEMA_LISTS and isinstance(value, list):
                resolved[key] = [inline(item, within) for item in value]
            elif key in _SUBSCHEMA_MAPS and isinstance(value, dict):
                resolved[key] = {field: inline(item, within) for field, item in value.items()}
            else:
                resolved[key] = value
        kind = resolved.get("type")
        if kind == "number":
            resolved["type"] = ["number", "string"]
        elif isinstance(kind, list) and "number" in kind and "string" not in kind:
            resolved["type"] = [*kind, "string"]
        return resolved

    try:
        inlined = inline(dict(schema), ())
    except RecursionError:
        raise CorruptLogError(log, "the robot-state schema is nested too deep") from None
    return {"$schema": _DIALECT, **inlined}


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


def _write_mcap(part: Path, session: _Session, replayed: ReplayResult | None) -> None:
    log, header = session.log, session.header
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
        robot_state = channels.add(
            "/robot_state",
            header.robot_state_type or "beatlog.RobotState",
            _viewer_schema(header.robot_state_schema, log),
        )
        behaviors = {
            name: channels.add(f"/behaviors/{name}", "beatlog.BehaviorState", _BEHAVIOR_SCHEMA)
            for name in header.behaviors
        }
        state_changes = channels.add("/state_changes", "foxglove.Log", _FOXGLOVE_LOG_SCHEMA)
        outputs = channels.add("/outputs", "beatlog.Outputs", _OUTPUTS_SCHEMA)
        random_numbers = channels.add("/random_numbers", "beatlog.RandomNumbers", _RANDOM_SCHEMA)
        heartbeat = channels.add("/heartbeat", "beatlog.Heartbeat", _HEARTBEAT_SCHEMA)
        divergence = None if replayed is None else replayed.divergence
        found = (
            None
            if divergence is None
            else channels.add("/divergence", "beatlog.Divergence", _DIVERGENCE_SCHEMA)
        )
        states = dict(session.initial)
        write = channels.write
        for cycle in session.cycles:
            number = cycle.number
            write(robot_state, cycle, cycle.robot_state, "robot state")
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
                    write(channel, cycle, {"cycle": 0, "state": states[name]}, "behavior state")
            for change in cycle.changes:
                lane = behaviors.get(change.behavior)
                if number > 0 and lane is not None:
                    write(lane, cycle, {"cycle": number, "state": change.after}, "behavior state")
                write(state_changes, cycle, _log_message(cycle.time_ns, change), "state change")
            write(outputs, cycle, {"cycle": number, "outputs": cycle.outputs}, "outputs")
            if cycle.draws:
                write(random_numbers, cycle, _draws_message(cycle), "random numbers")
            if found is not None and divergence is not None and divergence.cycle == number:
                message = _divergence_message(divergence, replayed.reproduce if replayed else "")
                write(found, cycle, message, "divergence")
        writer.finish()  # type: ignore[no-untyped-call]


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


def _draws_message(cycle: _Cycle) -> dict[str, Any]:
    return {
        "cycle": cycle.number,
        "draws": [
            {"actor": actor, "kind": draw.kind, "value": draw.value, "params": draw.params}
            for actor, draw in cycle.draws
        ],
    }


def _divergence_message(divergence: Divergence, reproduce: str) -> dict[str, Any]:
    def changes(which: Sequence[StateChange]) -> list[dict[str, Any]]:
        return [change._asdict() for change in which]

    return {
        "cycle": divergence.cycle,
        "kind": divergence.kind.value,
        "message": divergence.message,
        "behavior": divergence.behavior,
        "expected": changes(divergence.expected),
        "actual": changes(divergence.actual),
        "reproduce": reproduce,
    }


# Tables

_FIRST_COLUMNS = ("cycle", "time_ns", "heartbeat_ns")
_DRAWS_COLUMN = "draws"


def _write_table(part: Path, session: _Session, chosen: ExportFormat) -> None:
    log = session.log
    states = dict(session.initial)
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
