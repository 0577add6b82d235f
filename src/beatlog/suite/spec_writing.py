"""DTC specs written as TOML text: a new one beside a recording (:func:`spec_text`), one
made from another's data (:func:`spec_toml`, what ``beatlog shrink`` writes), and the
strings in them (:func:`toml_string`). :mod:`beatlog.suite.spec` reads them back."""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from typing import Any

__all__ = ["spec_text", "spec_toml", "toml_string"]


def spec_text(
    *,
    name: str,
    purpose: str,
    procedure: Iterable[str],
    log: str,
    system: str | None,
    tags: Iterable[str] = (),
    perception: str | None = None,
    invariants: Iterable[str] = (),
    variants: Mapping[str, Any] | None = None,
) -> str:
    """A new spec as TOML text, for tools that write one beside a recording (``beatlog
    import-bag --spec``, a suite's recording script, a failing variant); ``log`` is
    relative to the spec, and a spec without ``system`` replays the one its log records.
    ``variants`` is its ``[variants]`` table, where it declares variants."""
    lines = [
        f"name = {toml_string(name)}",
        f"purpose = {toml_string(purpose)}",
        "procedure = [",
        *(f"    {toml_string(step)}," for step in procedure),
        "]",
        f"log = {toml_string(log)}",
        *([] if system is None else [f"system = {toml_string(system)}"]),
        *([] if perception is None else [f"perception = {toml_string(perception)}"]),
        f"tags = [{', '.join(map(toml_string, tags))}]",
    ]
    if checked := list(invariants):
        lines += ["invariants = [", *(f"    {toml_string(name)}," for name in checked), "]"]
    if variants is not None:
        table = (f"{_toml_key(key)} = {_toml_value(value)}" for key, value in variants.items())
        lines += ["", "[variants]", *table]
    return "\n".join(lines) + "\n"


def spec_toml(data: Mapping[str, Any]) -> str:
    """A spec's data (strings, numbers, booleans, arrays and tables of them, as
    :func:`~beatlog.suite.spec.read_spec_data` reads them) as TOML text: its keys
    first, then its tables."""
    tables = {key: value for key, value in data.items() if isinstance(value, Mapping)}
    lines = [
        f"{_toml_key(key)} = {_toml_value(value)}"
        for key, value in data.items()
        if key not in tables
    ]
    for name, table in tables.items():
        lines.extend(["", f"[{_toml_key(name)}]"])
        lines.extend(f"{_toml_key(key)} = {_toml_value(value)}" for key, value in table.items())
    return "\n".join(lines) + "\n"


def _toml_key(key: str) -> str:
    """A TOML key: bare where TOML allows it, else quoted."""
    bare = key and all(c.isascii() and (c.isalnum() or c in "-_") for c in key)
    return key if bare else toml_string(key)


def _toml_value(value: object) -> str:
    """A TOML value of a spec's data: inline tables within its tables."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)  # TOML spells inf and nan as Python does
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(map(_toml_value, value)) + "]"
    if isinstance(value, Mapping):
        items = ", ".join(f"{_toml_key(key)} = {_toml_value(item)}" for key, item in value.items())
        return "{ " + items + " }" if items else "{}"
    raise TypeError(f"no TOML for {value!r}")


def toml_string(text: str) -> str:
    """A TOML basic string: JSON's escapes, and DEL escaped too (TOML forbids it bare)."""
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")
