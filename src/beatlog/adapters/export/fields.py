"""The JSON shape of exported values: a typed field model the viewers' schema parser
reads, inferred from values or built from the header's robot-state schema, and the
writing of values under it (NaN and ±inf left out and listed, bytes as base64)."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from enum import Enum
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from beatlog.errors import CorruptLogError
from beatlog.model.behavior import BehaviorState

__all__ = [
    "BASE64",
    "BY_TYPE",
    "GAP",
    "JSON_TEXT",
    "NON_FINITE",
    "NON_FINITE_SCHEMA",
    "Field",
    "Kind",
    "add_types",
    "array_field",
    "inferred",
    "json_text",
    "json_type",
    "merged",
    "object_field",
    "state_text",
    "too_deep",
    "typed_object",
    "with_number_texts",
    "written_object",
    "written_value",
]


_JSON = msgspec.json.Encoder()


def _jsonable(value: Any) -> Any:
    """``value`` with NaN and ±inf as strings and map keys as strings; JSON encodes the
    rest (bytes as base64)."""
    if isinstance(value, float):
        if math.isfinite(value):
            return value
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, dict):
        return {
            key if isinstance(key, str) else _JSON.encode(_jsonable(key)).decode(): _jsonable(item)
            for key, item in value.items()
        }
    if isinstance(value, list | tuple):
        return [_jsonable(item) for item in value]
    return value


def json_text(value: Any, log: Path, where: str) -> bytes:
    try:
        return _JSON.encode(_jsonable(value))
    except (TypeError, msgspec.EncodeError, RecursionError) as exc:
        raise CorruptLogError(log, f"{where} cannot be written as JSON: {exc}") from None


def state_text(state: BehaviorState) -> str:
    """A behavior state as a viewer shows it: a string as it is, anything else as JSON."""
    return state if isinstance(state, str) else json.dumps(state)


# MCAP: what a field is for the viewers


class Kind(Enum):
    NUMBER = "a JSON number; NaN and ±inf are left out and listed in non_finite"
    NUMBER_TEXT = "a number in an array as its text: 0.5, NaN, Infinity, -Infinity"
    PLAIN = "an integer, boolean or string, written as it is"
    OBJECT = "an object with its own fields"
    ARRAY = "an array of numbers, number texts, integers, booleans, strings or objects"
    JSON = "a string holding the value's JSON text"


class Field(NamedTuple):
    """A field as the viewers get it: its JSON schema and how a value is written."""

    schema: dict[str, Any]
    kind: Kind
    fields: Mapping[str, Field] = {}
    """An object's fields."""
    items: Field | None = None
    """An array's items (None: not known, the log holds only empty arrays)."""


NON_FINITE = "non_finite"
NON_FINITE_SCHEMA = {
    "type": "array",
    "items": {"type": "string"},
    "description": "The fields left out of this message because their value is NaN or "
    "infinite, as path=value: distance=NaN, outputs.speed=-Infinity, blips[1].x=NaN.",
}
JSON_TEXT = {
    "type": "string",
    "description": 'JSON text of the value: NaN and ±inf as the strings "NaN", "Infinity" '
    'and "-Infinity", bytes as base64.',
}
BY_TYPE = {
    "number": Field({"type": "number"}, Kind.NUMBER),
    "integer": Field({"type": "integer"}, Kind.PLAIN),
    "boolean": Field({"type": "boolean"}, Kind.PLAIN),
    "string": Field({"type": "string"}, Kind.PLAIN),
    "json": Field(JSON_TEXT, Kind.JSON),
}
BASE64 = Field({"type": "string", "contentEncoding": "base64"}, Kind.PLAIN)
_NUMBER_TEXT = Field(
    {
        "type": "string",
        "description": "A number as its text (0.5); NaN and ±inf as NaN, Infinity and -Infinity.",
    },
    Kind.NUMBER_TEXT,
)
_NUMBERS = (BY_TYPE["number"], BY_TYPE["integer"], _NUMBER_TEXT)
_ARRAY_ITEMS = frozenset({Kind.NUMBER, Kind.NUMBER_TEXT, Kind.PLAIN, Kind.OBJECT})
GAP = object()
"""What a value left out of its message is written as."""


def object_field(fields: Mapping[str, Field]) -> Field:
    """An object of ``fields``, by name."""
    properties = {name: field.schema for name, field in fields.items()}
    return Field({"type": "object", "properties": properties}, Kind.OBJECT, fields)


def array_field(items: Field | None) -> Field:
    """An array of ``items`` (of numbers while they are not known), or JSON text if the
    viewers cannot type an array of them."""
    if items is None:
        return Field({"type": "array", "items": {"type": "number"}}, Kind.ARRAY)
    if items.kind in _ARRAY_ITEMS and items is not BASE64:
        return Field({"type": "array", "items": items.schema}, Kind.ARRAY, items=items)
    return BY_TYPE["json"]


def written_value(field: Field, value: Any, path: str, non_finite: list[str]) -> Any:
    """``value`` as ``field`` declares it, or ``GAP`` for a null, NaN or ±inf (listed in
    ``non_finite`` as ``path=value``)."""
    if value is None:
        return GAP
    kind = field.kind
    if kind is Kind.NUMBER:
        if isinstance(value, float) and not math.isfinite(value):
            non_finite.append(f"{path}={json.dumps(value)}")
            return GAP
        return value
    if kind is Kind.OBJECT:
        return written_object(field.fields, value, f"{path}.", non_finite)
    if kind is Kind.ARRAY:
        items = field.items
        if items is None or items.kind is Kind.NUMBER:
            return value  # finite: the first read made an array holding NaN or ±inf texts
        return [
            written_value(items, item, f"{path}[{i}]", non_finite) for i, item in enumerate(value)
        ]
    if kind is Kind.NUMBER_TEXT:
        return json.dumps(value) if isinstance(value, int | float) else _json_value(value)
    if kind is Kind.JSON:
        return _json_value(value)
    return value


def _json_value(value: Any) -> str:
    return _JSON.encode(_jsonable(value)).decode()


def written_object(
    fields: Mapping[str, Field], value: Mapping[str, Any], prefix: str, non_finite: list[str]
) -> dict[str, Any]:
    """The declared fields of ``value`` (a field the schema lacks is left out)."""
    written = {}
    for name, field in fields.items():
        if name in value:
            item = written_value(field, value[name], f"{prefix}{name}", non_finite)
            if item is not GAP:
                written[name] = item
    return written


def json_type(value: Any) -> str:
    """The JSON-schema type of a value read from the log (``json`` for lists, maps, bytes)."""
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "number"
    return "string" if isinstance(value, str) else "json"


def add_types(fields: dict[str, Field | None], values: Mapping[str, Any]) -> None:
    """Merge the types of ``values`` into ``fields`` (see :func:`merged`: integers and
    floats make a number, any other mix is JSON text); one always null stays None."""
    for name, value in values.items():
        typed = None if value is None else BY_TYPE[json_type(value)]
        fields[name] = merged(fields.get(name), typed)


def typed_object(fields: Mapping[str, Field | None]) -> Field:
    """An object of the fields a first read of the log found, typed as it found them."""
    return object_field({name: field or BY_TYPE["json"] for name, field in fields.items()})


def with_number_texts(field: Field, value: Any) -> Field:
    """``field`` with each array of numbers that holds a NaN or ±inf in ``value`` made an
    array of their texts, which JSON can hold with NaN and ±inf in it."""
    if field.kind is Kind.OBJECT and isinstance(value, dict):
        changed = {
            name: texts
            for name, inner in field.fields.items()
            if name in value and (texts := with_number_texts(inner, value[name])) is not inner
        }
        return object_field({**field.fields, **changed}) if changed else field
    items = field.items
    if items is None or not isinstance(value, list):
        return field
    if items.kind is Kind.NUMBER:
        finite = all(not isinstance(item, float) or math.isfinite(item) for item in value)
        return field if finite else array_field(_NUMBER_TEXT)
    for item in value if items.kind is Kind.OBJECT else ():
        items = with_number_texts(items, item)
    return field if items is field.items else array_field(items)


def inferred(value: Any, log: Path, cycle: int) -> Field | None:
    """The field that ``value``, read from the log, is for a channel typed from the log's
    values (None for a null); see :func:`_value_field`."""
    try:
        return _value_field(value, in_array=False)
    except RecursionError:
        raise too_deep(log, cycle) from None


def too_deep(log: Path, cycle: int) -> CorruptLogError:
    return CorruptLogError(log, f"a sample of cycle {cycle} is nested too deep")


def _value_field(value: Any, *, in_array: bool) -> Field | None:
    """A null is None; a map with string keys an object, a list an array (of number texts
    if one of its numbers is NaN or ±inf); what the viewers cannot type is JSON text."""
    if value is None:
        return None
    if isinstance(value, float) and in_array and not math.isfinite(value):
        return _NUMBER_TEXT
    if isinstance(value, bytes):
        return BASE64
    if isinstance(value, dict):
        if not all(isinstance(key, str) for key in value):
            return BY_TYPE["json"]
        fields = {}
        for name, item in value.items():
            inner = _value_field(item, in_array=False)
            if inner is not None:
                fields[name] = inner
        return object_field(fields)
    if isinstance(value, list):
        items: Field | None = None
        for item in value:
            inner = _value_field(item, in_array=True)
            if inner is None:
                return BY_TYPE["json"]  # an array of nullables
            items = merged(items, inner)
        return array_field(items)
    return BY_TYPE[json_type(value)]


def merged(seen: Field | None, field: Field | None) -> Field | None:
    """One field for the values of two: objects merge their fields, arrays their items,
    integers and numbers make numbers (number texts if either is); any other mix is
    JSON text."""
    if seen is None or seen == field:
        return field
    if field is None:
        return seen
    if seen.kind is field.kind is Kind.OBJECT:
        fields = dict(seen.fields)
        for name, inner in field.fields.items():
            fields[name] = merged(fields.get(name), inner) or inner
        return object_field(fields)
    if seen.kind is field.kind is Kind.ARRAY:
        return array_field(merged(seen.items, field.items))
    if seen in _NUMBERS and field in _NUMBERS:
        return _NUMBER_TEXT if _NUMBER_TEXT in (seen, field) else BY_TYPE["number"]
    return BY_TYPE["json"]
