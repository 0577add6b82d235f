"""Whether a session log fits the system it is replayed against.

A log fits when every robot-state field it recorded exists in the system's robot
state with the same type, and every field the system's state added since has a
default. The type's name may differ (a class moved or renamed). Anything else would
replay on a state silently filled with defaults, so it is bad input, never a verdict.
A behavior the system lacks is not checked here: that is a verdict, with rename
proposals, because behavior changes are what DTCs exist to catch.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from beatlog.errors import CorruptLogError, FieldError, SchemaMismatchError
from beatlog.log.format import SessionHeader
from beatlog.model.behavior import System
from beatlog.model.state import state_schema, state_type_name

__all__ = ["check_fit", "check_state_fields", "state_differences"]

_IGNORED_KEYS = frozenset({"default", "title", "description", "examples"})
_MAX_REF_DEPTH = 32
_SHOWN = 3


def check_fit(header: SessionHeader, system: System, path: Path) -> None:
    """Raise :class:`SchemaMismatchError` naming both sides when the log does not fit.

    :raises beatlog.errors.CorruptLogError: the log's robot-state schema is not a schema.
    """
    try:
        problems = state_differences(header.robot_state_schema, state_schema(system.robot_state))
    except (RecursionError, TypeError, KeyError, AttributeError) as exc:
        raise CorruptLogError(path, f"damaged robot-state schema in the header: {exc!r}") from None
    if not problems:
        return
    shown = "; ".join(problems[:_SHOWN])
    more = f"; and {len(problems) - _SHOWN} more" if len(problems) > _SHOWN else ""
    raise SchemaMismatchError(
        path,
        f"recorded with robot state {header.robot_state_type}, which does not fit the "
        f"system's {state_type_name(system.robot_state)}: {shown}{more}",
    )


def check_state_fields(header: SessionHeader, names: Iterable[str], path: Path, what: str) -> None:
    """Raise :class:`FieldError` naming the log when a field named (``what`` says where,
    e.g. a tolerance) is not in the robot state the log recorded.

    :raises beatlog.errors.CorruptLogError: the log's robot-state schema is not a schema.
    """
    schema = header.robot_state_schema
    try:
        recorded = _resolve(schema, schema, 0).get("properties", {})
    except (RecursionError, TypeError, KeyError, AttributeError) as exc:
        raise CorruptLogError(path, f"damaged robot-state schema in the header: {exc!r}") from None
    unknown = [name for name in names if name not in recorded]
    if unknown:
        raise FieldError(
            f"{path}: {what} {unknown[0]!r}: the recorded robot state "
            f"{header.robot_state_type} has no such field (it has {', '.join(recorded)})"
        )


def state_differences(recorded: dict[str, Any], current: dict[str, Any]) -> list[str]:
    """What keeps a state recorded with schema ``recorded`` from loading as ``current``."""
    recorded_root = _resolve(recorded, recorded, 0)
    current_root = _resolve(current, current, 0)
    recorded_fields = recorded_root.get("properties", {})
    current_fields = current_root.get("properties", {})
    problems = []
    for name, field in recorded_fields.items():
        if name not in current_fields:
            problems.append(f"field {name!r} is gone")
        elif _normal(field, recorded, 0) != _normal(current_fields[name], current, 0):
            problems.append(
                f"field {name!r} was {_describe(field, recorded)}, "
                f"is now {_describe(current_fields[name], current)}"
            )
    required = set(current_root.get("required", ()))
    for name in current_fields:
        if name not in recorded_fields and name in required:
            problems.append(f"field {name!r} is new and has no default")
    return problems


def _resolve(node: dict[str, Any], document: dict[str, Any], depth: int) -> dict[str, Any]:
    while isinstance(node, dict) and "$ref" in node:
        if depth > _MAX_REF_DEPTH:
            raise RecursionError("robot-state schema references nest too deep")
        *_, name = str(node["$ref"]).split("/")
        node = document["$defs"][name]
        depth += 1
    return node


def _normal(node: Any, document: dict[str, Any], depth: int) -> Any:
    """A schema node with references resolved and documentation-only keys left out."""
    if depth > _MAX_REF_DEPTH:
        return "..."
    if isinstance(node, dict):
        node = _resolve(node, document, depth)
        return {
            key: _normal(value, document, depth + 1)
            for key, value in node.items()
            if key not in _IGNORED_KEYS
        }
    if isinstance(node, list):
        return [_normal(item, document, depth + 1) for item in node]
    return node


def _describe(node: Any, document: dict[str, Any]) -> str:
    """A short name for a field's type: ``number``, ``array``, ``Pose`` or ``a|b``."""
    if isinstance(node, dict):
        if "$ref" in node:
            return str(node["$ref"]).rsplit("/", 1)[-1]
        if "anyOf" in node:
            return "|".join(_describe(option, document) for option in node["anyOf"])
        if "type" in node:
            return str(node["type"])
        if "enum" in node:
            return "enum"
    return "another type"
