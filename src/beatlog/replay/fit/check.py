"""The fit check: a log's robot state, behaviors and any migration the user gives
against the system's, each misfit one message naming both sides (and the spec keys
that fix it, where renames or conversions would)."""

from __future__ import annotations

import difflib
import functools
import json
import platform
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from beatlog.errors import CorruptLogError, FieldError, SchemaMismatchError
from beatlog.log.format import SessionHeader
from beatlog.model.behavior import System
from beatlog.model.state import state_schema, state_type_name
from beatlog.project.config import one_to_one_problem
from beatlog.replay.fit.migration import NO_MIGRATION, StateMigration
from beatlog.replay.fit.schema import (
    PROBLEMS,
    FieldDifference,
    Sides,
    field_differences,
    field_names_at,
    field_schema,
    renamed_schema,
    schema_fields,
)

__all__ = [
    "check_catalogue",
    "check_fit",
    "check_state_fields",
    "period_note",
    "python_note",
    "state_differences",
]

_SHOWN = 3
_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
"""A TOML key that needs no quotes."""


# Made once per type, not once a replay: buys 8.1 % of a whole replay of a 1,000-field
# state stored by field, after another (600.5 -> 551.6 M instructions, cachegrind).
_schema_of = functools.lru_cache(maxsize=64)(state_schema)
"""The JSON schema of a system's robot state type, made once per type: a suite replays
many logs against one robot. Read only, never changed."""


def check_fit(
    header: SessionHeader,
    system: System,
    path: Path,
    migration: StateMigration = NO_MIGRATION,
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
        current = _schema_of(system.robot_state)
        if migration:
            _check_migration(header, system, current, migration, path)
            recorded = renamed_schema(recorded, migration.renames)
        differences = field_differences(recorded, current, frozenset(migration.conversions))
        same_fields = schema_fields(recorded).keys() == schema_fields(current).keys()
        problems = _problems(differences)
        hints = _hints(differences, recorded, current) if problems else ""
    except (RecursionError, TypeError, KeyError, AttributeError) as exc:
        raise CorruptLogError(path, f"damaged robot-state schema in the header: {exc!r}") from None
    # the types' names without their modules: what stays when a class moves
    was = header.robot_state_type.rsplit(".", 1)[-1]
    now = state_type_name(system.robot_state).rsplit(".", 1)[-1]
    if was != now and not (same_fields and not problems):
        foreign = _foreign(header, differences, recorded, current, (was, now))
        if foreign:
            problems.insert(0, foreign)
            hints = ""
        else:
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


def _foreign(
    header: SessionHeader,
    differences: list[FieldDifference],
    recorded: dict[str, Any],
    current: dict[str, Any],
    names: tuple[str, str],
) -> str:
    """Why a log of another robot state type looks like another robot's log, or nothing
    when it does not: most of the fields it recorded are gone or retyped (a struct whose
    fields changed inside counts as kept), and the renames proposed explain no more than
    half of them. Renames proposed for the few fields left would mislead."""
    fields = len(schema_fields(recorded))
    kept = fields - sum(
        difference.kind in ("gone", "retyped") and "." not in difference.path
        for difference in differences
    )
    renamed = sum("." not in old for old in _proposed_renames(differences, recorded, current))
    if 2 * kept >= fields or 2 * (kept + renamed) > fields:
        return ""
    robot = f" (robot {header.robot_id!r})" if header.robot_id else ""
    was, now = names
    return (
        f"this looks like another robot's log{robot}: {now} holds only {kept} of the "
        f"{fields} fields {was} recorded"
    )


def period_note(header: SessionHeader, system: System) -> str | None:
    """A note on a log recorded at another heartbeat period than the one the system
    declares (its ``period_ns``), or None: no failure, since the behaviors replay the
    recorded beats, but open loop from the first cycle."""
    declared = getattr(system, "period_ns", None)
    if not isinstance(declared, int) or declared == header.period_ns:
        return None
    return (
        f"heartbeat period: the log was recorded at {header.period_ns / 1e6:g} ms, the "
        f"system runs at {declared / 1e6:g} ms; the behaviors replay the recorded "
        "heartbeats, so this DTC runs open loop from cycle 0 (record it again at the new "
        "period)"
    )


def python_note(header: SessionHeader, *, diverged: bool) -> str | None:
    """A note on a diverged replay under another Python minor version than the session
    was recorded under, which may compute floats otherwise; None otherwise."""
    recorded = header.recorded_python()
    replaying = platform.python_version()
    if not diverged or recorded is None or _minor(recorded) == _minor(replaying):
        return None
    return (
        f"recorded under Python {recorded}, replayed under {replaying}: Python may compute "
        "otherwise across versions (3.12 adds floats in sum() more exactly), so replay "
        "under the robot's Python to tell a change of code from a change of Python"
    )


def _minor(version: str) -> str:
    return ".".join(version.split(".")[:2])


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
        near = difflib.get_close_matches(leaf, field_names_at(document, parent), n=1)
        meant = "".join(f" (did you mean {(f'{parent}.{n}' if parent else n)!r}?)" for n in near)
        return refuse(what, f"{sides[id(document)]} has no field {name!r}{meant}")

    renames = migration.renames
    problem = one_to_one_problem(renames)
    if problem is not None:
        raise refuse("field renames", problem)
    for old, new in renames.items():
        what = f"field rename {old} -> {new}"
        if field_schema(recorded, old) is None:
            raise missing(what, recorded, old)
        if field_schema(current, new) is None:
            raise missing(what, current, new)
        staying = migration.current_name(old)
        if staying != new:
            raise refuse(what, f"a field renamed stays in its struct: it becomes {staying!r}")
        twin = ".".join([*old.split(".")[:-1], new.rsplit(".", 1)[-1]])
        if twin != old and twin not in renames and field_schema(recorded, twin) is not None:
            raise refuse(what, f"the log records {twin!r} too: rename that as well")
    mapped = [*migration.conversions, *renames.values()]
    for name, reference in migration.conversions.items():
        what = f"field conversion {name} = {reference}"
        if name in renames and field_schema(current, name) is None:
            raise refuse(what, f"a conversion names the field as it is now: {renames[name]!r}")
        if field_schema(current, name) is None:
            raise missing(what, current, name)
        old = migration.recorded_name(name)
        if field_schema(recorded, old) is None:
            raise missing(what, recorded, old)
        inside = [other for other in mapped if other.startswith(name + ".")]
        if inside:
            raise refuse(
                what, f"{inside[0]!r} lies inside the field converted: its conversion maps it"
            )


def _hints(differences: list[FieldDifference], recorded: Any, current: Any) -> str:
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
    differences: list[FieldDifference], recorded: Any, current: Any
) -> dict[str, tuple[str, Any]]:
    """Each field gone mapped to a new field of its struct that holds its values (the
    nearest name where several do), with the new field's schema."""
    added = [d for d in differences if d.kind in ("added", "required")]
    sides = Sides(recorded, current)
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


def _problems(differences: list[FieldDifference]) -> list[str]:
    """The differences that keep a state from loading, each in words."""
    said = {"gone": "is gone", "required": "is new and has no default"}
    return [
        f"field {found.path!r} "
        + (
            said.get(found.kind)
            or f"was {_describe(found.recorded)}, is now {_describe(found.current)}"
        )
        for found in differences
        if found.kind in PROBLEMS
    ]


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


def check_state_fields(
    header: SessionHeader,
    names: Iterable[str],
    path: Path,
    what: str,
    migration: StateMigration = NO_MIGRATION,
) -> None:
    """Raise :class:`FieldError` naming the log when a field named (``what`` says where,
    e.g. a tolerance) is not in the robot state the log recorded (under its current
    name, by ``migration``).

    :raises beatlog.errors.CorruptLogError: the log's robot-state schema is not a schema.
    """
    try:
        recorded = [
            migration.current_name(name) for name in schema_fields(header.robot_state_schema)
        ]
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
    return _problems(field_differences(recorded, current, frozenset()))


def _listed(names: Sequence[str]) -> str:
    """Names for a message: the first few, then how many more."""
    more = f" and {len(names) - _SHOWN} more" if len(names) > _SHOWN else ""
    return ", ".join(names[:_SHOWN]) + more


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
