"""Whether a session log fits the system it is replayed against.

A log fits when its robot state is the system's: the same type (its module may have
moved; a type renamed since keeps exactly its fields), every robot-state field it
recorded in the system's state with a type that holds the recorded values (the same,
or a wider one: an int that became a float, a type that became optional, a nested
struct that gained fields with defaults), and every field the system's state added
since with a default. A field renamed or retyped otherwise since the recording is
mapped by a :class:`~beatlog.replay.migration.StateMigration` the user gives (a
spec's ``field_renames`` and ``field_conversions``); one that is not leaves a message
proposing the rename. Anything else would replay on a state silently filled with
defaults, so it is bad input, never a verdict. The same goes for a log none of whose
behaviors is the system's (:func:`check_catalogue`): another robot's log. A behavior
the system lacks among others is a verdict, with rename proposals, because behavior
changes are what DTCs exist to catch.

:func:`recorded_state_type` is the system's robot state as the log's cycles must hold
it, so that a cycle filled in with defaults or holding a field nobody declared is
caught while it is decoded.
"""

from __future__ import annotations

import copy
import difflib
import functools
import json
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from beatlog.errors import CorruptLogError, FieldError, SchemaMismatchError
from beatlog.log.format import SessionHeader
from beatlog.model.behavior import System
from beatlog.model.state import state_schema, state_type_name
from beatlog.project import one_to_one_problem
from beatlog.replay.migration import StateMigration

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
_NO_MIGRATION = StateMigration()
_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
"""A TOML key that needs no quotes."""


class _Difference(NamedTuple):
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


_PROBLEMS = ("gone", "retyped", "required")


def check_fit(
    header: SessionHeader,
    system: System,
    path: Path,
    migration: StateMigration = _NO_MIGRATION,
) -> None:
    """Raise :class:`SchemaMismatchError` naming both sides when the log does not fit,
    its fields renamed and converted by ``migration``; the message proposes the
    migration for fields that look renamed or retyped.

    :raises beatlog.errors.FieldError: ``migration`` names a field the log or the system
        lacks, renames two fields to one, or converts a field it also maps inside.
    :raises beatlog.errors.CorruptLogError: the log's robot-state schema is not a schema.
    """
    recorded = header.robot_state_schema
    try:
        current = state_schema(system.robot_state)
        if migration:
            _check_migration(header, system, current, migration, path)
            recorded = _renamed_schema(recorded, migration.renames)
        # The common case, a log of the system's own robot state, compared in C.
        differences = (
            []
            if recorded == current and not migration
            else _differences(recorded, current, frozenset(migration.conversions))
        )
        same_fields = _fields(recorded).keys() == _fields(current).keys()
        problems = [_message(found) for found in differences if found.kind in _PROBLEMS]
        hints = _hints(differences, recorded, current) if problems else ""
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
        f"system's {state_type_name(system.robot_state)}: {shown}{more}{hints}",
    )


def _check_migration(
    header: SessionHeader,
    system: System,
    current: dict[str, Any],
    migration: StateMigration,
    path: Path,
) -> None:
    """Raise :class:`FieldError` naming the log when ``migration`` does not fit it and
    the system: see :func:`check_fit`."""
    recorded = header.robot_state_schema
    sides = {
        id(recorded): f"the recorded robot state {header.robot_state_type}",
        id(current): f"the system's robot state {state_type_name(system.robot_state)}",
    }

    def refuse(what: str, problem: str) -> FieldError:
        return FieldError(f"{path}: {what}: {problem}")

    def missing(what: str, document: dict[str, Any], name: str) -> FieldError:
        parent, _, leaf = name.rpartition(".")
        near = difflib.get_close_matches(leaf, _names_at(document, parent), n=1)
        meant = "".join(f" (did you mean {(f'{parent}.{n}' if parent else n)!r}?)" for n in near)
        return refuse(what, f"{sides[id(document)]} has no field {name!r}{meant}")

    renames = migration.renames
    problem = one_to_one_problem(renames)
    if problem is not None:
        raise refuse("field renames", problem)
    for old, new in renames.items():
        what = f"field rename {old} -> {new}"
        if _lookup(recorded, old) is None:
            raise missing(what, recorded, old)
        if _lookup(current, new) is None:
            raise missing(what, current, new)
        staying = migration.current_name(old)
        if staying != new:
            raise refuse(what, f"a field renamed stays in its struct: it becomes {staying!r}")
        twin = ".".join([*old.split(".")[:-1], new.rsplit(".", 1)[-1]])
        if twin != old and twin not in renames and _lookup(recorded, twin) is not None:
            raise refuse(what, f"the log records {twin!r} too: rename that as well")
    mapped = [*migration.conversions, *renames.values()]
    for name, reference in migration.conversions.items():
        what = f"field conversion {name} = {reference}"
        if name in renames and _lookup(current, name) is None:
            raise refuse(what, f"a conversion names the field as it is now: {renames[name]!r}")
        if _lookup(current, name) is None:
            raise missing(what, current, name)
        old = migration.recorded_name(name)
        if _lookup(recorded, old) is None:
            raise missing(what, recorded, old)
        inside = [other for other in mapped if other.startswith(name + ".")]
        if inside:
            raise refuse(
                what, f"{inside[0]!r} lies inside the field converted: its conversion maps it"
            )


def _hints(differences: list[_Difference], recorded: Any, current: Any) -> str:
    """What to add to the spec for fields that look renamed or retyped since."""
    hints = ""
    renames = _proposed_renames(differences, recorded, current)
    if renames:
        news = " and ".join(
            f"{new!r} ({_describe(current_node)})" for new, current_node in renames.values()
        )
        table = ", ".join(
            f"{_toml_key(old)} = {json.dumps(new)}" for old, (new, _) in renames.items()
        )
        options = " ".join(f"--rename-field {old}={new}" for old, (new, _) in renames.items())
        place = "its place" if len(renames) == 1 else "their place"
        hints += (
            f"; the system has {news} in {place}: if renamed, add field_renames = "
            f"{{ {table} }} to the spec (beatlog replay: {options})"
        )
    retyped = next((d.path for d in differences if d.kind == "retyped"), None)
    if retyped is not None:
        hints += (
            f"; a field retyped since takes a conversion: field_conversions = "
            f'{{ {_toml_key(retyped)} = "module:function" }} in the spec (beatlog replay: '
            f"--convert-field {retyped}=module:function)"
        )
    return hints


def _proposed_renames(
    differences: list[_Difference], recorded: Any, current: Any
) -> dict[str, tuple[str, Any]]:
    """Each field gone mapped to a new field of its struct that holds its values (the
    nearest name where several do), with the new field's schema."""
    added = [d for d in differences if d.kind in ("added", "required")]
    sides = _Sides(recorded, current)
    proposed: dict[str, tuple[str, Any]] = {}
    taken: set[str] = set()
    for gone in (d for d in differences if d.kind == "gone"):
        parent, _, leaf = gone.path.rpartition(".")
        candidates = {
            new.path.rpartition(".")[2]: new
            for new in added
            if new.path.rpartition(".")[0] == parent
            and new.path not in taken
            and sides.fits(gone.recorded, new.current)
        }
        near = (
            list(candidates)
            if len(candidates) == 1
            else difflib.get_close_matches(leaf, list(candidates), n=1)
        )
        if near:
            chosen = candidates[near[0]]
            proposed[gone.path] = (chosen.path, chosen.current)
            taken.add(chosen.path)
    return proposed


def _toml_key(name: str) -> str:
    """A field's name as a key of a TOML inline table: bare where it may be."""
    return name if _BARE_KEY.fullmatch(name) else json.dumps(name)


def _message(difference: _Difference) -> str:
    name = difference.path
    if difference.kind == "gone":
        return f"field {name!r} is gone"
    if difference.kind == "required":
        return f"field {name!r} is new and has no default"
    return f"field {name!r} was {_describe(difference.recorded)}, is now " + _describe(
        difference.current
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


def recorded_state_type(
    header: SessionHeader, state_type: type[Any], migration: StateMigration = _NO_MIGRATION
) -> type[Any]:
    """The system's robot state type as each cycle of the log must hold it: every field
    the header's schema records is required and no field the type lacks is allowed.

    A subclass of ``state_type`` under the same name, so that msgspec checks each RS_t
    while decoding it; a state decoded with it becomes an instance of ``state_type``
    itself by setting its ``__class__``. Fields the type gained since the recording keep
    their defaults, as do all where the type omits defaults when encoding, and a
    positional field after an optional one. A field ``migration`` renames is read under
    its recorded name, and one it converts (or maps inside) as the log holds it, for a
    :class:`~beatlog.replay.migration.StateConverter` to convert. The log must fit the
    system (:func:`check_fit`).
    """
    if not (isinstance(state_type, type) and issubclass(state_type, msgspec.Struct)):
        return state_type
    omitted = state_type.__struct_config__.omit_defaults
    recorded = () if omitted else _fields(header.robot_state_schema)
    return _checking_type(
        state_type,
        frozenset(map(migration.current_name, recorded) if migration.renames else recorded),
        tuple((new, old) for old, new in migration.renames.items() if "." not in old),
        migration.converted(),
    )


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
            default = _default(field) if optional and not required else {}
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


def _default(field: msgspec.structs.FieldInfo) -> dict[str, Any]:
    """The default of an optional field, as :func:`msgspec.field` takes it."""
    if field.default_factory is not msgspec.NODEFAULT:
        return {"default_factory": field.default_factory}
    return {"default": field.default}


def check_state_fields(
    header: SessionHeader,
    names: Iterable[str],
    path: Path,
    what: str,
    migration: StateMigration = _NO_MIGRATION,
) -> None:
    """Raise :class:`FieldError` naming the log when a field named (``what`` says where,
    e.g. a tolerance) is not in the robot state the log recorded (under its current
    name, by ``migration``).

    :raises beatlog.errors.CorruptLogError: the log's robot-state schema is not a schema.
    """
    try:
        recorded = [migration.current_name(name) for name in _fields(header.robot_state_schema)]
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
    return [
        _message(difference)
        for difference in _differences(recorded, current, frozenset())
        if difference.kind in _PROBLEMS
    ]


def _differences(
    recorded: dict[str, Any], current: dict[str, Any], skipped: frozenset[str]
) -> list[_Difference]:
    """How the fields of two robot-state schemas differ, nested structs field by field;
    the fields ``skipped`` (current names, dotted) are not compared."""
    found: list[_Difference] = []
    _Sides(recorded, current).compare(
        _resolve(recorded, recorded, 0), _resolve(current, current, 0), "", skipped, found
    )
    return found


class _Sides(NamedTuple):
    """The recorded robot-state schema and the system's, whose nodes refer into them."""

    recorded: dict[str, Any]
    current: dict[str, Any]

    def compare(
        self,
        was: dict[str, Any],
        now: dict[str, Any],
        prefix: str,
        skipped: frozenset[str],
        found: list[_Difference],
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
                found.append(_Difference("gone", path, field, None))
                continue
            later = current_fields[name]
            if _normal(field, self.recorded, depth) == _normal(later, self.current, depth):
                continue
            was_struct = _struct(field, self.recorded)
            is_struct = _struct(later, self.current)
            if was_struct is not None and is_struct is not None:
                self.compare(was_struct, is_struct, f"{path}.", skipped, found, depth=depth + 1)
            elif not self.fits(field, later, depth):
                found.append(_Difference("retyped", path, field, later))
        required = set(now.get("required", ()))
        for name, field in current_fields.items():
            if name not in recorded_fields:
                kind = "required" if name in required else "added"
                found.append(_Difference(kind, prefix + name, None, field))

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
            found: list[_Difference] = []
            self.compare(was_struct, is_struct, "", frozenset(), found, depth=depth + 1)
            return not any(difference.kind in _PROBLEMS for difference in found)

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


def _lookup(document: dict[str, Any], name: str) -> Any:
    """The schema of the field ``name`` (dotted through nested structs); None if none."""
    node: Any = _resolve(document, document, 0)
    for part in name.split("."):
        struct = _struct(node, document)
        if struct is None or part not in struct["properties"]:
            return None
        node = struct["properties"][part]
    return node


def _names_at(document: dict[str, Any], parent: str) -> list[str]:
    """The fields of the struct at ``parent`` (a dotted name; the root when empty)."""
    node = _lookup(document, parent) if parent else document
    struct = _struct(node, document)
    return [] if struct is None else list(struct["properties"])


def _renamed_schema(document: dict[str, Any], renames: Mapping[str, str]) -> dict[str, Any]:
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


def _describe(node: Any) -> str:
    """A short name for a field's type: ``number``, ``array of number``, ``map of
    string``, ``Pose``, ``"a"|"b"`` (an enum) or ``a|b``."""
    if isinstance(node, dict):
        if "$ref" in node:
            return str(node["$ref"]).rsplit("/", 1)[-1]
        if "anyOf" in node:
            return "|".join(_describe(option) for option in node["anyOf"])
        if isinstance(node.get("enum"), list):
            values = [json.dumps(value) for value in node["enum"]]
            return "|".join(values[:_SHOWN] + (["…"] if len(values) > _SHOWN else []))
        if isinstance(node.get("items"), dict):
            return f"array of {_describe(node['items'])}"
        if isinstance(node.get("additionalProperties"), dict):
            return f"map of {_describe(node['additionalProperties'])}"
        if "type" in node:
            return str(node["type"])
    return "another type"
