"""The JSON schemas of the MCAP export's channels, in the one shape Foxglove's and
Lichtblick's schema parser reads (see :mod:`beatlog.adapters.export`).

Two are Foxglove's well-known schemas as published in foxglove/foxglove-sdk
(``schemas/jsonschema/*.json``): the name makes Foxglove's panels take the channel (the
Log panel a ``foxglove.Log``, the 3D panel a ``foxglove.FrameTransform``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from beatlog.adapters.export.fields import JSON_TEXT, NON_FINITE, NON_FINITE_SCHEMA, Field
from beatlog.replay.verdict import DivergenceKind

__all__ = [
    "BEHAVIOR_SCHEMA",
    "DIVERGENCE_SCHEMA",
    "FRAME_TRANSFORM_SCHEMA",
    "HEARTBEAT_SCHEMA",
    "LOG_SCHEMA",
    "RANDOM_SCHEMA",
    "outputs_schema",
    "robot_state_schema",
    "sample_schema",
]


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


HEARTBEAT_SCHEMA = _record_schema(
    "beatlog.Heartbeat",
    "The heartbeat interval HB_t that ended this cycle.",
    interval_ns={"type": "integer", "minimum": 0},
    interval_ms={"type": "number", "minimum": 0},
)
BEHAVIOR_SCHEMA = _record_schema(
    "beatlog.BehaviorState",
    'A behavior\'s state after this cycle; "null" when the log never shows it (it never changes).',
    state=_STATE,
)
RANDOM_SCHEMA = _record_schema(
    "beatlog.RandomNumbers",
    "The random numbers drawn in this cycle, in draw order (RN_t).",
    draws={
        "type": "array",
        "items": {
            "type": "object",
            "properties": {
                "actor": {"type": "string", "description": "The behavior, or 'system'."},
                "kind": {"type": "string"},
                "value": JSON_TEXT,
                "params": JSON_TEXT,
            },
            "required": ["actor", "kind", "value", "params"],
            "additionalProperties": False,
        },
    },
)
DIVERGENCE_SCHEMA = _record_schema(
    "beatlog.Divergence",
    "The first cycle where replaying the log against a system differed from it.",
    kind={"type": "string", "enum": list(DivergenceKind)},
    message={"type": "string"},
    behavior={"type": "string", "description": "The behavior it concerns; empty if none."},
    expected={"type": "array", "items": _CHANGE},
    actual={"type": "array", "items": _CHANGE},
    reproduce={"type": "string"},
)


def _time(description: str) -> dict[str, Any]:
    return {
        "type": "object",
        "title": "time",
        "properties": {
            "sec": {"type": "integer", "minimum": 0},
            "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999},
        },
        "description": description,
    }


def _numbers(title: str, description: str, names: str, what: str) -> dict[str, Any]:
    return {
        "title": title,
        "description": description,
        "type": "object",
        "properties": {name: {"type": "number", "description": f"{name} {what}"} for name in names},
        "required": list(names),
    }


# foxglove.Log, except its level: there a oneOf of the level constants, which
# Lichtblick's parser rejects in releases that predate its enum support, here an integer.
LOG_SCHEMA = {
    "title": "Log",
    "description": "A log message",
    "type": "object",
    "properties": {
        "timestamp": _time("Timestamp of log message"),
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
FRAME_TRANSFORM_SCHEMA = {
    "title": "foxglove.FrameTransform",
    "description": "A transform between two reference frames in 3D space. The transform "
    "defines the position and orientation of a child frame within a parent frame. Foxglove "
    "applies the translation first and then the rotation.",
    "type": "object",
    "properties": {
        "timestamp": _time("Timestamp of transform"),
        "parent_frame_id": {"type": "string", "description": "Name of the parent frame"},
        "child_frame_id": {"type": "string", "description": "Name of the child frame"},
        "translation": _numbers(
            "foxglove.Vector3",
            "Translation component of the transform, representing the position of the "
            "child frame's origin in the parent frame.",
            "xyz",
            "coordinate length",
        ),
        "rotation": _numbers(
            "foxglove.Quaternion",
            "Rotation component of the transform, representing the orientation of the "
            "child frame in the parent frame",
            "xyzw",
            "value",
        ),
    },
    "required": ["timestamp", "parent_frame_id", "child_frame_id", "translation", "rotation"],
}


def robot_state_schema(title: str, robot_state: Field) -> dict[str, Any]:
    return {
        "$schema": _DIALECT,
        "title": title,
        **robot_state.schema,
        "properties": {**robot_state.schema["properties"], NON_FINITE: NON_FINITE_SCHEMA},
    }


def sample_schema(sensor: str, value: Field) -> dict[str, Any]:
    return _record_schema(
        "beatlog.Sample",
        f"A raw sample of sensor {sensor!r} folded into RS_t in this cycle, typed as a first "
        "read of the log found its values (a null is left out).",
        optional=["value", NON_FINITE],
        stamp_ns={"type": "integer", "description": "The sample's own time stamp (ns)."},
        value=value.schema,
        non_finite=NON_FINITE_SCHEMA,
    )


def outputs_schema(outputs: Field) -> dict[str, Any]:
    return _record_schema(
        "beatlog.Outputs",
        "What the behaviors output in this cycle, e.g. motor commands, typed as a first "
        "read of the log found them (lists, maps and mixed types as JSON text).",
        optional=[NON_FINITE],
        outputs=outputs.schema,
        non_finite=NON_FINITE_SCHEMA,
    )
