"""Robot-state schemas: how the recorded one and the system's differ, field by field,
for the fit check to word; and the type the log's cycles must fit
(:func:`recorded_state_type`), so that a cycle missing a field or holding one nobody
declared is caught while it is decoded.
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Mapping
from typing import Any, NamedTuple

import msgspec

from beatlog.log.format import SessionHeader
from beatlog.replay.fit.migration import NO_MIGRATION, StateMigration

__all__ = [
    "PROBLEMS",
    "FieldDifference",
    "Sides",
    "field_differences",
    "field_names_at",
    "field_schema",
    "recorded_state_type",
    "renamed_schema",
    "schema_fields",
]

_IGNORED_KEYS = frozenset({"default", "title", "description", "examples"})
_MAX_REF_DEPTH = 32


class FieldDifference(NamedTuple):
    """One way a recorded robot-state field and the system's differ."""

    kind: str
    """``gone``, ``retyped``, ``required`` (new and without a default) or ``added`` (new,
    with a default: no problem, but where a field gone may have been renamed to)."""
    path: str
    """The field's name, dotted for a field of a nested struct."""
    recorded: Any
    """The recorded field's schema (None for a new field)."""
    current: Any
    """The system's field's schema (None for a field gone)."""


PROBLEMS = ("gone", "retyped", "required")


def field_differences(
    recorded: dict[str, Any], current: dict[str, Any], skipped: frozenset[str]
) -> list[FieldDifference]:
    """How the fields of two robot-state schemas differ, nested structs field by field;
    the fields ``skipped`` (current names, dotted) are not compared."""
    found: list[FieldDifference] = []
    Sides(recorded, current).compare(
        _resolve(recorded, recorded, 0), _resolve(current, current, 0), "", skipped, found
    )
    return found


class Sides(NamedTuple):
    """The recorded robot-state schema and the system's, whose nodes refer into them."""

    recorded: dict[str, Any]
    current: dict[str, Any]

    def compare(
        self,
        was: dict[str, Any],
        now: dict[str, Any],
        prefix: str,
        skipped: frozenset[str],
        found: list[FieldDifference],
        *,
        depth: int = 0,
    ) -> None:
        """Add to ``found`` how the fields of two struct schemas differ."""
        if depth > _MAX_REF_DEPTH:
            raise RecursionError("robot-state schema structs nest too deep")
        recorded_fields = was.get("properties", {})
        current_fields = now.get("properties", {})
        for name, field in recorded_fields.items():
            path = prefix + name
            if path in skipped:
                continue
            if name not in current_fields:
                found.append(FieldDifference("gone", path, field, None))
                continue
            later = current_fields[name]
            if _normal(field, self.recorded, depth) == _normal(later, self.current, depth):
                continue
            was_struct = _struct(field, self.recorded)
            is_struct = _struct(later, self.current)
            if was_struct is not None and is_struct is not None:
                self.compare(was_struct, is_struct, f"{path}.", skipped, found, depth=depth + 1)
            elif not self.fits(field, later, depth):
                found.append(FieldDifference("retyped", path, field, later))
        required = set(now.get("required", ()))
        for name, field in current_fields.items():
            if name not in recorded_fields:
                kind = "required" if name in required else "added"
                found.append(FieldDifference(kind, prefix + name, None, field))

    def fits(self, recorded: Any, current: Any, depth: int = 0) -> bool:
        """Whether every value of the recorded schema node decodes as the current one:
        the same type, or a wider one (int into float, into a union holding it, a
        struct that gained fields with defaults, a list, set or dict of such, an enum
        with more members)."""
        if _normal(recorded, self.recorded, depth) == _normal(current, self.current, depth):
            return True
        if depth > _MAX_REF_DEPTH or not (isinstance(recorded, dict) and isinstance(current, dict)):
            return False
        was = _resolve(recorded, self.recorded, depth)
        now = _resolve(current, self.current, depth)
        if "anyOf" in was or "anyOf" in now:
            options = now.get("anyOf", [now])
            return all(
                any(self.fits(old, new, depth + 1) for new in options)
                for old in was.get("anyOf", [was])
            )
        old: dict[str, Any] = _normal(was, self.recorded, depth)
        new: dict[str, Any] = _normal(now, self.current, depth)
        if old == {"type": "integer"}:
            return new == {"type": "number"}
        was_struct, is_struct = _struct(was, self.recorded), _struct(now, self.current)
        if was_struct is not None and is_struct is not None:
            found: list[FieldDifference] = []
            self.compare(was_struct, is_struct, "", frozenset(), found, depth=depth + 1)
            return not any(difference.kind in PROBLEMS for difference in found)

        def same_but(key: str) -> bool:
            return {k: v for k, v in old.items() if k != key} == {
                k: v for k, v in new.items() if k != key
            }

        for key in ("items", "additionalProperties"):
            if isinstance(was.get(key), dict) and isinstance(now.get(key), dict):
                return same_but(key) and self.fits(was[key], now[key], depth + 1)
        if isinstance(was.get("enum"), list) and isinstance(now.get("enum"), list):
            return same_but("enum") and all(value in now["enum"] for value in was["enum"])
        return False


def _struct(node: Any, document: dict[str, Any]) -> dict[str, Any] | None:
    """The schema of a struct (an object with properties), resolved; None for another."""
    if not isinstance(node, dict):
        return None
    resolved = _resolve(node, document, 0)
    return resolved if isinstance(resolved.get("properties"), dict) else None


def field_schema(document: dict[str, Any], name: str) -> Any:
    """The schema of the field ``name`` (dotted through nested structs); None if none."""
    node: Any = _resolve(document, document, 0)
    for part in name.split("."):
        struct = _struct(node, document)
        if struct is None or part not in struct["properties"]:
            return None
        node = struct["properties"][part]
    return node


def field_names_at(document: dict[str, Any], parent: str) -> list[str]:
    """The fields of the struct at ``parent`` (a dotted name; the root when empty)."""
    node = field_schema(document, parent) if parent else document
    struct = _struct(node, document)
    return [] if struct is None else list(struct["properties"])


def renamed_schema(document: dict[str, Any], renames: Mapping[str, str]) -> dict[str, Any]:
    """A copy of a robot-state schema with the fields ``renames`` names (recorded paths,
    checked to exist) under their new names, the structs on the way copied in place so
    that other fields of their types keep their names."""
    renamed = copy.deepcopy(document)
    by_struct: dict[str, dict[str, str]] = {}
    for old, new in renames.items():
        parent, _, leaf = old.rpartition(".")
        by_struct.setdefault(parent, {})[leaf] = new.rsplit(".", 1)[-1]
    for parent in sorted(by_struct, key=lambda name: -len(name.split("."))):
        node = _resolve(renamed, renamed, 0)
        for part in parent.split(".") if parent else ():
            properties = node["properties"]
            node = properties[part] = copy.deepcopy(_resolve(properties[part], renamed, 0))
        leaves = by_struct[parent]
        properties = node["properties"]
        moved = {leaves[name]: properties.pop(name) for name in leaves}
        properties.update(moved)
        node["required"] = [leaves.get(name, name) for name in node.get("required", ())]
    return renamed


def schema_fields(schema: dict[str, Any]) -> dict[str, Any]:
    """The fields a robot-state schema describes, by the names they are encoded with."""
    fields: dict[str, Any] = _resolve(schema, schema, 0).get("properties", {})
    return fields


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


def recorded_state_type(
    header: SessionHeader, state_type: type[Any], migration: StateMigration = NO_MIGRATION
) -> type[Any]:
    """The system's robot state type as each cycle of the log must hold it: every field
    the header's schema records is required and no field the type lacks is allowed.

    A subclass of ``state_type`` under the same name, so that msgspec checks each RS_t
    while decoding it. Fields gained since the recording keep their defaults, as do all
    where the type omits defaults, and a positional field after an optional one. A field
    ``migration`` renames is read under its recorded name, one it converts (or maps
    inside) as the log holds it. The log must fit the system
    (:func:`~beatlog.replay.fit.check.check_fit`).
    """
    if not (isinstance(state_type, type) and issubclass(state_type, msgspec.Struct)):
        return state_type
    omitted = state_type.__struct_config__.omit_defaults
    recorded = () if omitted else schema_fields(header.robot_state_schema)
    return _checking_type(
        state_type,
        frozenset(map(migration.current_name, recorded) if migration.renames else recorded),
        tuple((new, old) for old, new in migration.renames.items() if "." not in old),
        migration.converted(),
    )


# Made once, not once a replay (and so the views' shapes and the batch decoders made for
# it once too): buys 19 % of a whole replay of a 1,000-field state stored by field,
# after another (682.5 -> 551.6 M instructions, cachegrind).
@functools.lru_cache(maxsize=64)
def _checking_type(
    state_type: type[msgspec.Struct],
    recorded: frozenset[str],
    recorded_as: tuple[tuple[str, str], ...],
    as_logged: frozenset[str],
) -> type[Any]:
    """:func:`recorded_state_type` for the fields recorded (by encoded name), those
    recorded under another name (current, recorded) and those decoded as logged, made
    once: replaying many logs of one robot builds one type and its decoders' tables."""
    config = state_type.__struct_config__
    names = dict(recorded_as)
    positional: list[tuple[str, Any, Any]] = []
    keywords: list[tuple[str, Any, Any]] = []
    optional_before = False
    for field in msgspec.structs.fields(state_type):
        is_positional = field.name in state_type.__match_args__
        optional = not field.required
        name = names.get(field.encode_name, field.encode_name)
        kind = Any if field.encode_name in as_logged else field.type
        required = (
            optional and field.encode_name in recorded and not (is_positional and optional_before)
        )
        if optional and is_positional and not required:
            optional_before = True
        if required or name != field.encode_name or kind is not field.type:
            if not optional or required:
                default: dict[str, Any] = {}
            elif field.default_factory is not msgspec.NODEFAULT:
                default = {"default_factory": field.default_factory}
            else:
                default = {"default": field.default}
            spec = msgspec.field(name=name, **default)
            (positional if is_positional else keywords).append((field.name, kind, spec))
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
