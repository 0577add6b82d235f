"""The system's robot state type as the log's cycles must hold it, so that a cycle filled
in with defaults or holding a field nobody declared is caught while it is decoded."""

from __future__ import annotations

import functools
from typing import Any

import msgspec

from beatlog.log.format import SessionHeader
from beatlog.replay.migration import StateMigration
from beatlog.replay.schema_diff import schema_fields

__all__ = ["recorded_state_type"]

_NO_MIGRATION = StateMigration()


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
    system (:func:`~beatlog.replay.fit.check_fit`).
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
