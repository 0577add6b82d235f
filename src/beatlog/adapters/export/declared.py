"""The robot-state schema a log's header declares, as the viewers take it: the field
model (:mod:`beatlog.adapters.export.fields`) of an export typed from the header."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from beatlog.adapters.export.fields import (
    BASE64,
    BY_TYPE,
    Field,
    Kind,
    array_field,
    json_type,
    object_field,
)
from beatlog.errors import CorruptLogError

__all__ = ["declared_object"]

_MAX_SCHEMA_NODES = 100_000
"""A robot-state schema inlined beyond this many nodes is refused (a hostile header
could otherwise expand exponentially)."""


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
