"""The JSON schemas Foxglove and Lichtblick can read: a port of their schema parser.

Both viewers turn a channel's JSON schema into message definitions with
``parseJsonSchema`` in ``packages/mcap-support/src/parseJsonSchema.ts`` and refuse the
channel when it throws. Ported from that file as published in foxglove/studio
(commit 9abf66535509a1bc62df53a3508e627415a620e3) and in Lichtblick-Suite/lichtblick
(commits 4a0d75265661467d3a5b881928505dc0c2dca630 and
660985ee7fb002530647a8dfe763d89964d9cb11); this port accepts what all three accept:

- a schema (the top level, a field of type object, an array's object items) has
  ``"type": "object"`` and a ``properties`` map (``Object.entries`` of a missing one
  throws);
- every property has one ``type``, a string: ``boolean``, ``string``, ``number``,
  ``integer``, ``object`` (checked as a schema) or ``array``; ``null``, a list of
  types or no type is refused;
- a string's ``contentEncoding`` is absent or ``base64``;
- an array has ``items``, a schema whose ``type`` is ``boolean``, ``string`` (with no
  ``contentEncoding``), ``number``, ``integer`` or ``object`` (checked as a schema):
  no arrays of arrays;
- no property has a ``oneOf``: Foxglove and the newer Lichtblick take one of number
  ``const`` alternatives as an enum (and refuse any other), the older Lichtblick
  ignores ``oneOf`` and wants a ``type``.

Other keywords (``required``, ``enum``, ``minimum``, ``additionalProperties``, ...)
are ignored by the viewers and so here; a standard validator checks the messages.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

FIELD_TYPES = frozenset({"boolean", "string", "number", "integer", "object", "array"})
ITEM_TYPES = frozenset({"boolean", "string", "number", "integer", "object"})


class ViewerSchemaError(ValueError):
    """A schema the viewers refuse; the message names the field as a dotted path."""


def check_viewer_schema(schema: Mapping[str, Any]) -> None:
    """Raise ViewerSchemaError unless Foxglove and Lichtblick both parse ``schema``."""
    _check_object(schema, "<root>")


def _check_object(schema: Any, path: str) -> None:
    if not isinstance(schema, Mapping) or schema.get("type") != "object":
        kind = schema.get("type") if isinstance(schema, Mapping) else schema
        raise ViewerSchemaError(f'{path}: expected "type": "object", got {kind!r}')
    properties = schema.get("properties")
    if not isinstance(properties, Mapping):
        raise ViewerSchemaError(f"{path}: an object needs a properties map")
    for name, field in properties.items():
        _check_field(field, f"{path}.{name}")


def _check_field(field: Any, path: str) -> None:
    if not isinstance(field, Mapping):
        raise ViewerSchemaError(f"{path}: a field's schema must be an object")
    if "oneOf" in field:
        raise ViewerSchemaError(f"{path}: oneOf (an enum in Foxglove only)")
    kind = field.get("type")
    if not isinstance(kind, str) or kind not in FIELD_TYPES:
        raise ViewerSchemaError(f"{path}: unsupported type {kind!r}")
    if kind == "string" and field.get("contentEncoding") not in (None, "base64"):
        raise ViewerSchemaError(f"{path}: unsupported contentEncoding")
    if kind == "object":
        _check_object(field, path)
    if kind == "array":
        _check_items(field.get("items"), f"{path}[]")


def _check_items(items: Any, path: str) -> None:
    kind = items.get("type") if isinstance(items, Mapping) else None
    if not isinstance(kind, str) or kind not in ITEM_TYPES:
        raise ViewerSchemaError(f"{path}: unsupported array item type {kind!r}")
    if kind == "string" and items.get("contentEncoding") is not None:
        raise ViewerSchemaError(f"{path}: an array item has a contentEncoding")
    if kind == "object":
        _check_object(items, path)
