"""Reading a session log for export: its cycles decoded with behaviors and actors by
name, the robot-state schema its header declares as the viewers take it (the field
model of :mod:`beatlog.adapters.export.fields`), a first read that types what the
header does not declare, and the metadata every export carries."""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from beatlog.adapters.export.fields import (
    BASE64,
    BY_TYPE,
    Field,
    Kind,
    add_types,
    array_field,
    inferred,
    json_type,
    merged,
    object_field,
    typed_object,
    with_number_texts,
)
from beatlog.errors import CorruptLogError
from beatlog.log.format import DECODE_ERRORS, Draw, LoggedStateChange, SessionHeader
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.model.behavior import BehaviorState
from beatlog.model.inbox import Sample
from beatlog.replay.verdict import StateChange

__all__ = [
    "Cycle",
    "FirstRead",
    "Session",
    "decoded_cycles",
    "first_read",
    "log_metadata",
    "states_after",
]

_MAX_SCHEMA_NODES = 100_000
"""A robot-state schema inlined beyond this many nodes is refused (a hostile header
could otherwise expand exponentially)."""


class Cycle(NamedTuple):
    """One cycle of the log, decoded, with behaviors and actors by name."""

    number: int
    time_ns: int
    heartbeat_ns: int
    robot_state: dict[str, Any]
    changes: list[StateChange]
    draws: list[tuple[str, Draw]]
    outputs: dict[str, Any]
    samples: list[Sample]


class FirstRead(NamedTuple):
    """What a first pass over the log finds."""

    initial: Mapping[str, BehaviorState]
    """Each catalogue behavior's state at the start: the ``before`` of its first change
    (None for a behavior that never changes in the log)."""
    output_types: Mapping[str, Field | None]
    """Each output's field over the whole log (see ``add_types``)."""
    status: LogStatus
    """How the log ends."""
    robot_state: Field
    """The robot state's fields: as the header declares them, else as the log holds them."""
    viewed_state: Field
    """The robot state as the viewers get it: its arrays of numbers that hold a NaN or
    ±inf somewhere in the log are arrays of their texts."""
    samples: Mapping[str, Field | None]
    """Each sensor's sample values as the log holds them (None: only nulls)."""


class Session(NamedTuple):
    """What the writers read: the log, its header, its cycles decoded one by one, and
    what a first read of the log found."""

    log: Path
    header: SessionHeader
    cycles: Iterator[Cycle]
    first: FirstRead


def decoded_cycles(reader: SessionLogReader) -> Iterator[Cycle]:
    """The log's cycles, decoded; a msgpack extension, which beatlog never writes, is
    damage."""
    names = reader.header.behaviors
    decode_map = msgspec.msgpack.Decoder(dict[str, Any], ext_hook=_no_extension).decode
    decode_changes = msgspec.msgpack.Decoder(list[LoggedStateChange], ext_hook=_no_extension).decode
    decode_draws = msgspec.msgpack.Decoder(list[Draw], ext_hook=_no_extension).decode
    decode_samples = msgspec.msgpack.Decoder(list[Sample], ext_hook=_no_extension).decode
    time_ns = 0
    for number, record in enumerate(reader.cycles()):
        time_ns += record.heartbeat_ns
        try:
            state = decode_map(record.robot_state)
            changes = decode_changes(record.state_changes)
            draws = decode_draws(record.random_numbers)
            outputs = decode_map(record.outputs)
            samples = decode_samples(record.samples)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(reader.path, f"damaged cycle {number}: {exc}") from None
        yield Cycle(
            number,
            time_ns,
            record.heartbeat_ns,
            state,
            [StateChange(_name(names, index), before, after) for index, before, after in changes],
            [(_name(names, draw.actor), draw) for draw in draws],
            outputs,
            samples,
        )


def _no_extension(code: int, data: memoryview) -> Any:
    raise msgspec.DecodeError(f"a msgpack extension (type {code}), which no log holds")


def _name(catalogue: Sequence[str], index: int) -> str:
    if index < 0:
        return "system"
    return catalogue[index] if index < len(catalogue) else f"#{index}"


def declared_object(schema: Mapping[str, Any], log: Path) -> Field | None:
    """The header's robot-state schema as the viewers take it (None if it describes no
    object with properties): every ``$ref`` to ``#/$defs/...`` inlined; a number,
    integer, boolean or string as that type (an enum of strings or of integers too, a
    nullable one too: a null is left out); an object with properties and an array of
    those with their own schemas; anything else (a map, tuple, union, an array of
    arrays or of nullables, a type within itself) as JSON text."""
    definitions = schema.get("$defs")
    defs = definitions if isinstance(definitions, dict) else {}
    nodes = 0

    def field(node: Any, within: tuple[str, ...], nullable: bool) -> Field:
        nonlocal nodes
        nodes += 1
        if nodes > _MAX_SCHEMA_NODES:
            raise CorruptLogError(
                log, f"the robot-state schema inlines to more than {_MAX_SCHEMA_NODES} nodes"
            )
        if not isinstance(node, dict):
            return BY_TYPE["json"]
        reference = node.get("$ref")
        if reference is not None:
            name = reference.removeprefix("#/$defs/") if isinstance(reference, str) else ""
            if name == reference or name not in defs:
                raise CorruptLogError(
                    log, f"the robot-state schema refers to {reference!r}, which it lacks"
                )
            target = defs[name]
            if name in within or not isinstance(target, dict):
                return BY_TYPE["json"]
            rest = {key: value for key, value in node.items() if key != "$ref"}
            return field({**rest, **target}, (*within, name), nullable)
        kind = node.get("type")
        alternatives = node.get("anyOf", node.get("oneOf"))
        if isinstance(alternatives, list):
            others = [option for option in alternatives if option != {"type": "null"}]
            if not (nullable and len(others) == 1 == len(alternatives) - 1):
                return BY_TYPE["json"]
            return field(others[0], within, nullable=False)
        if isinstance(kind, list):
            others = [option for option in kind if option != "null"]
            kind = others[0] if nullable and len(others) == 1 == len(kind) - 1 else "json"
        enum = node.get("enum")
        if kind is None and isinstance(enum, list) and enum:
            kinds = {json_type(value) for value in enum}
            kind = kinds.pop() if len(kinds) == 1 else "json"
        properties = node.get("properties")
        items = node.get("items")
        if kind == "object" and isinstance(properties, dict):
            return object_field(
                {name: field(value, within, nullable=True) for name, value in properties.items()}
            )
        if kind == "array" and isinstance(items, dict) and "prefixItems" not in node:
            return array_field(field(items, within, nullable=False))
        if kind == "string" and node.get("contentEncoding") == "base64":
            return BASE64
        return BY_TYPE.get(kind if isinstance(kind, str) else "json", BY_TYPE["json"])

    try:
        declared = field(dict(schema), (), nullable=False)
    except RecursionError:
        raise CorruptLogError(log, "the robot-state schema is nested too deep") from None
    return declared if declared.kind is Kind.OBJECT else None


def first_read(log: Path) -> FirstRead:
    with SessionLogReader(log) as reader:
        header = reader.header
        states: dict[str, BehaviorState] = header.initial_states_by_name()
        output_types: dict[str, Field | None] = {}
        declared = declared_object(header.robot_state_schema, log)
        viewed = declared
        state_types: dict[str, Field | None] = {}
        samples: dict[str, Field | None] = {}
        for cycle in decoded_cycles(reader):
            for change in cycle.changes:
                states.setdefault(change.behavior, change.before)
            add_types(output_types, cycle.outputs)
            if viewed is None:
                add_types(state_types, cycle.robot_state)
            else:
                viewed = with_number_texts(viewed, cycle.robot_state)
            for sample in cycle.samples:
                samples[sample.sensor] = merged(
                    samples.get(sample.sensor), inferred(sample.value, log, cycle.number)
                )
        initial = {name: states.get(name) for name in header.behaviors}
        robot_state = typed_object(state_types) if declared is None else declared
        return FirstRead(
            initial, output_types, reader.status, robot_state, viewed or robot_state, samples
        )


def states_after(states: dict[str, BehaviorState], changes: Sequence[StateChange]) -> None:
    """Apply a cycle's changes of catalogue behaviors to ``states``."""
    for change in changes:
        if change.behavior in states:
            states[change.behavior] = change.after


def log_metadata(session: Session) -> dict[str, str]:
    """What an export says of its log, as text: its header, and how and where it ends."""
    header, status = session.header, session.first.status
    return {
        "log": session.log.name,
        "format_version": str(header.format_version),
        "robot_id": header.robot_id,
        "software_version": header.software_version,
        "python_version": header.recorded_python() or "unknown",
        "system": header.system,
        "robot_state_type": header.robot_state_type,
        "period_ns": str(header.period_ns),
        "start_time_ns": str(header.start_time_ns),
        "cycles": str(status.cycles),
        "complete": "true" if status.complete else "false",
        "status": status.describe(),
    }
