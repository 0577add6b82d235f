"""The JSON schemas of the MCAP export's channels, in the one shape Foxglove's and
Lichtblick's schema parser reads (see :mod:`beatlog.adapters.export`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from beatlog.adapters.export.fields import JSON_TEXT, NON_FINITE, NON_FINITE_SCHEMA, Field
from beatlog.replaying.verdict import DivergenceKind

__all__ = [
    "BEHAVIOR_SCHEMA",
    "DIVERGENCE_SCHEMA",
    "HEARTBEAT_SCHEMA",
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
