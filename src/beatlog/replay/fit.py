"""Whether a session log fits the system it is replayed against.

A log fits when its robot state is the system's: the same type (its module may have
moved; a type renamed since keeps exactly its fields), every robot-state field it
recorded in the system's state with the same type, and every field the system's state
added since with a default. Anything else would replay on a state silently filled
with defaults, so it is bad input, never a verdict. The same goes for a log none of
whose behaviors is the system's (:func:`check_catalogue`): another robot's log. A
behavior the system lacks among others is a verdict, with rename proposals, because
behavior changes are what DTCs exist to catch.

:func:`recorded_state_type` is the system's robot state as the log's cycles must hold
it, so that a cycle filled in with defaults or holding a field nobody declared is
caught while it is decoded.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import msgspec

from beatlog.errors import CorruptLogError, FieldError, SchemaMismatchError
from beatlog.log.format import SessionHeader
from beatlog.model.behavior import System
from beatlog.model.state import state_schema, state_type_name

__all__ = [
    "check_catalogue",
    "check_fit",
    "check_state_fields",
    "recorded_state_type",
    "state_differences",
]

_IGNORED_KEYS = frozenset({"default", "title", "description", "examples"})
_MAX_REF_DEPTH = 32
_SHOWN = 3


def check_fit(header: SessionHeader, system: System, path: Path) -> None:
    """Raise :class:`SchemaMismatchError` naming both sides when the log does not fit.

    :raises beatlog.errors.CorruptLogError: the log's robot-state schema is not a schema.
    """
    recorded = header.robot_state_schema
    try:
        current = state_schema(system.robot_state)
        # The common case, a log of the system's own robot state, compared in C.
        problems = [] if recorded == current else state_differences(recorded, current)
        same_fields = _fields(recorded).keys() == _fields(current).keys()
    except (RecursionError, TypeError, KeyError, AttributeError) as exc:
        raise CorruptLogError(path, f"damaged robot-state schema in the header: {exc!r}") from None
    was = _short_name(header.robot_state_type)
    now = _short_name(state_type_name(system.robot_state))
    if was != now and not (same_fields and not problems):
        problems.insert(
            0, f"{was} is not {now} (a robot state type renamed since keeps exactly its fields)"
        )
    if not problems:
        return
    shown = "; ".join(problems[:_SHOWN])
    more = f"; and {len(problems) - _SHOWN} more" if len(problems) > _SHOWN else ""
    raise SchemaMismatchError(
        path,
        f"recorded with robot state {header.robot_state_type}, which does not fit the "
        f"system's {state_type_name(system.robot_state)}: {shown}{more}",
    )


def check_catalogue(
    header: SessionHeader, system: System, path: Path, renames: Mapping[str, str]
) -> None:
    """Raise :class:`SchemaMismatchError` naming the log when none of the behaviors it
    recorded (under their current names, by ``renames``) is the system's.

    A log that recorded no behavior fits any catalogue.
    """
    catalogue = set(system.behaviors)
    if not header.behaviors or any(
        renames.get(name, name) in catalogue for name in header.behaviors
    ):
        return
    raise SchemaMismatchError(
        path,
        f"the log's behaviors {_listed(header.behaviors)} are not the system's "
        f"({_listed(list(system.behaviors))}): another robot's log? (behaviors renamed "
        "since the recording are mapped with renames in the spec)",
    )


def recorded_state_type(header: SessionHeader, state_type: type[Any]) -> type[Any]:
    """The system's robot state type as each cycle of the log must hold it: every field
    the header's schema records is required and no field the type lacks is allowed.

    A subclass of ``state_type`` under the same name, so that msgspec checks each RS_t
    while decoding it; a state decoded with it becomes an instance of ``state_type``
    itself by setting its ``__class__``. Fields the type gained since the recording keep
    their defaults, as do all where the type omits defaults when encoding, and a
    positional field after an optional one. The log must fit the system
    (:func:`check_fit`).
    """
    if not (isinstance(state_type, type) and issubclass(state_type, msgspec.Struct)):
        return state_type
    omitted = state_type.__struct_config__.omit_defaults
    return _checking_type(
        state_type, frozenset(() if omitted else _fields(header.robot_state_schema))
    )


@functools.lru_cache(maxsize=64)
def _checking_type(state_type: type[msgspec.Struct], recorded: frozenset[str]) -> type[Any]:
    """:func:`recorded_state_type` for the fields recorded (by encoded name), made once:
    replaying many logs of one robot builds one type and its decoders' tables."""
    config = state_type.__struct_config__
    positional: list[tuple[str, Any, Any]] = []
    keywords: list[tuple[str, Any, Any]] = []
    optional_before = False
    for field in msgspec.structs.fields(state_type):
        is_positional = field.name in state_type.__match_args__
        optional = not field.required
        if optional and field.encode_name in recorded and not (is_positional and optional_before):
            rename = msgspec.field(name=field.encode_name)
            (positional if is_positional else keywords).append((field.name, field.type, rename))
        elif optional and is_positional:
            optional_before = True
    strict: type[Any] = state_type
    levels = [level for level in ((positional, False), (keywords, True)) if level[0]]
    for fields, kw_only in levels or [(keywords, True)]:
        strict = msgspec.defstruct(
            state_type.__name__,
            fields,
            bases=(strict,),
            module=state_type.__module__,
            kw_only=kw_only,
            forbid_unknown_fields=True,
            frozen=False,  # so that a decoded state may become an instance of state_type
            namespace={"__qualname__": state_type.__qualname__},
            tag=config.tag,
        )
    return strict


def check_state_fields(header: SessionHeader, names: Iterable[str], path: Path, what: str) -> None:
    """Raise :class:`FieldError` naming the log when a field named (``what`` says where,
    e.g. a tolerance) is not in the robot state the log recorded.

    :raises beatlog.errors.CorruptLogError: the log's robot-state schema is not a schema.
    """
    try:
        recorded = _fields(header.robot_state_schema)
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


def _fields(schema: dict[str, Any]) -> dict[str, Any]:
    """The fields a robot-state schema describes, by the names they are encoded with."""
    fields: dict[str, Any] = _resolve(schema, schema, 0).get("properties", {})
    return fields


def _short_name(type_name: str) -> str:
    """A robot state type's name without its module: what stays when the class moves."""
    return type_name.rsplit(".", 1)[-1]


def _listed(names: Sequence[str]) -> str:
    """Names for a message: the first few, then how many more."""
    more = f" and {len(names) - _SHOWN} more" if len(names) > _SHOWN else ""
    return ", ".join(names[:_SHOWN]) + more


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
