"""Robot-state fields renamed or retyped since a recording, and how its RS_t still replay.

Recordings are immutable: a :class:`StateMigration` says how the recorded values reach
today's fields. It is the user's word (a spec, ``pyproject.toml``, ``beatlog replay
--rename-field``), never the log's: a conversion is imported only from a reference the
user gave. A renamed field of the robot state itself costs nothing per cycle (RS_t is
decoded under its recorded name); a converted field, or one with renamed fields inside,
is turned into the system's type as each cycle is decoded (:class:`StateConverter`).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

import msgspec

from beatlog.errors import ConversionError
from beatlog.project.usercode import load_conversion, user_traceback

__all__ = ["NO_MIGRATION", "StateConverter", "StateMigration"]


@dataclass(frozen=True)
class StateMigration:
    """How the robot state a log recorded maps onto the system's, where its fields were
    renamed or retyped since the recording; empty (false) when none was.

    ``renames`` maps a recorded field's name to its current one; a field of a nested
    struct is named by its dotted path on both sides and stays in its struct
    (``{"pose.x": "pose.px"}``). ``conversions`` maps a current field's name (or dotted
    path) to the ``module:function`` that turns its recorded value, as the log holds it
    (a struct as a dict, a tuple as a list), into a value of the field's type. Names
    are the fields' names as logged (a struct's encoded names).
    """

    renames: Mapping[str, str] = field(default_factory=dict)
    conversions: Mapping[str, str] = field(default_factory=dict)

    def __bool__(self) -> bool:
        return bool(self.renames or self.conversions)

    def current_name(self, recorded: str) -> str:
        """The current name (dotted path) of a field recorded as ``recorded``."""
        return _mapped(recorded, self.renames)

    def recorded_name(self, current: str) -> str:
        """The name (dotted path) a current field was recorded under."""
        return _mapped(current, {new: old for old, new in self.renames.items()})

    def converted(self) -> frozenset[str]:
        """The fields of the robot state itself (current names) whose recorded values
        are turned into the system's each cycle: those converted and those with a
        converted or renamed field inside."""
        inner = (new for new in self.renames.values() if "." in new)
        return frozenset(name.split(".", 1)[0] for name in (*self.conversions, *inner))

    def arguments(self) -> tuple[str, ...]:
        """The ``beatlog replay`` options that give this migration."""
        options = (("--rename-field", self.renames), ("--convert-field", self.conversions))
        return tuple(
            word
            for option, pairs in options
            for name, value in pairs.items()
            for word in (option, f"{name}={value}")
        )


NO_MIGRATION = StateMigration()
"""No field renamed or retyped since the recording."""


def _mapped(name: str, renames: Mapping[str, str]) -> str:
    """``name`` with each struct on its path, and the field itself, under its name by
    ``renames`` (whose keys and values are whole paths)."""
    if not renames:
        return name
    parts = name.split(".")
    return ".".join(
        renames[path].rsplit(".", 1)[-1] if path in renames else part
        for path, part in zip(_prefixes(parts), parts, strict=True)
    )


def _prefixes(parts: list[str]) -> Iterator[str]:
    """``a``, ``a.b``, ``a.b.c`` for the parts of ``a.b.c``."""
    return itertools.accumulate(parts, lambda path, part: f"{path}.{part}")


@dataclass
class _Fix:
    """What becomes of one recorded value: its current name, its conversion, and the
    fields inside it that were renamed or converted (by their recorded names)."""

    name: str
    reference: str = ""
    convert: Callable[[Any], Any] | None = None
    inner: dict[str, _Fix] = field(default_factory=dict)

    def apply(self, value: Any, path: str) -> Any:
        """The recorded ``value`` converted, or with its inner fields renamed and
        converted; a :class:`~beatlog.errors.ConversionError` where the conversion raised."""
        if self.convert is not None:
            try:
                return self.convert(value)
            except (Exception, SystemExit) as exc:  # the user's conversion failing is bad input
                raise ConversionError(
                    path,
                    f"{self.reference} raised {type(exc).__name__}: {exc}",
                    user_traceback=user_traceback(exc),
                ) from None
        if self.inner and isinstance(value, dict):
            found = [(fix, value.pop(key)) for key, fix in self.inner.items() if key in value]
            for fix, inner in found:
                value[fix.name] = fix.apply(inner, f"{path}.{fix.name}")
        return value


class StateConverter:
    """Turns the recorded values of a migration's :meth:`~StateMigration.converted`
    fields, decoded as the log holds them, into the system's types, in a robot state
    that is already the system's type.

    Building one imports the conversions (only ever from the user's references).

    :raises beatlog.errors.SystemLoadError: a conversion cannot be imported.
    """

    def __init__(self, state_type: type[Any], migration: StateMigration) -> None:
        fields = {info.encode_name: info for info in msgspec.structs.fields(state_type)}
        roots: dict[str, _Fix] = {}
        inner = [new for new in migration.renames.values() if "." in new]
        for path in dict.fromkeys([*migration.conversions, *inner]):
            parts = path.split(".")
            fix = roots.setdefault(parts[0], _Fix(parts[0]))
            for prefix, part in zip(list(_prefixes(parts))[1:], parts[1:], strict=True):
                recorded = migration.recorded_name(prefix).rsplit(".", 1)[-1]
                fix = fix.inner.setdefault(recorded, _Fix(part))
            reference = migration.conversions.get(path)
            if reference is not None:
                fix.reference, fix.convert = reference, load_conversion(reference)
        self._fields = {fields[name].name: (fields[name].type, fix) for name, fix in roots.items()}
        self.fields = frozenset(self._fields)
        """The fields (attribute names) it converts."""

    def __call__(self, state: Any) -> None:
        """Convert the fields of ``state`` in place, as :meth:`value` converts each."""
        for attribute in self._fields:
            setattr(state, attribute, self.value(attribute, getattr(state, attribute)))

    def value(self, attribute: str, recorded: Any) -> Any:
        """The recorded value of field ``attribute`` (one of :attr:`fields`), converted.

        :raises beatlog.errors.ConversionError: the conversion raised, or the value does not fit the
            field's type once converted.
        """
        kind, fix = self._fields[attribute]
        value = fix.apply(recorded, fix.name)
        try:
            return msgspec.convert(value, kind)
        except msgspec.ValidationError as exc:
            kind_name = getattr(kind, "__name__", str(kind))
            raise ConversionError(
                fix.name, f"the recorded value does not fit {kind_name} once converted: {exc}"
            ) from None
