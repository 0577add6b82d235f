"""The project's own configuration: ``[tool.beatlog]`` in the nearest ``pyproject.toml``,
the user's word for every spec (renames, conversions, invariants, variants, open-loop
limits, the systems the project vouches for). Bytes from a log never choose code: a
log's recorded ``module:factory`` is used only when the project lists it under
``systems`` (:func:`vouched_system`).
"""

from __future__ import annotations

import difflib
import functools
import re
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any

import msgspec

from beatlog.errors import SpecError, SystemLoadError
from beatlog.log.files import project_root

__all__ = [
    "ProjectConfig",
    "VariantsConfig",
    "check_conversions",
    "check_one_to_one",
    "check_references",
    "dotted_keys",
    "explain_validation",
    "keys_problem",
    "one_to_one_problem",
    "project_config",
    "variants_table",
    "vouched_system",
]

_SHOWN = 80
"""The most characters of a recorded reference an error repeats (it comes from a log)."""
_FIELD_TABLES = frozenset({"field_renames", "field_conversions"})
"""The tables keyed by robot-state fields, where a dotted key names a nested field."""


class VariantsConfig(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """A ``[variants]`` table: how many variants of a DTC run and what they perturb
    (:class:`~beatlog.replay.variant.Perturbations`); a key left out is the
    project's, or the default. A spec's comes on top of the project's."""

    count: Annotated[int, msgspec.Meta(ge=0)] | None = None
    """Variants run per DTC unless ``beatlog test --variants`` says otherwise."""
    draws: bool | None = None
    """Whether every random number is drawn fresh (default true)."""
    heartbeat_jitter: Annotated[float, msgspec.Meta(ge=0)] | None = None
    """The +- bound, in seconds, on each heartbeat interval's offset."""
    noise: dict[str, float] = {}
    """The +- bound per numeric robot-state field (dotted paths for nested fields)."""
    drop_samples: Annotated[float, msgspec.Meta(ge=0, le=1)] | None = None
    """Sensor-level DTCs: the share of samples dropped."""
    delay_samples: Annotated[float, msgspec.Meta(ge=0, le=1)] | None = None
    """Sensor-level DTCs: the share of samples delayed by one cycle."""


def variants_table(table: Any) -> Any:
    """A ``[variants]`` table as read from TOML, its ``noise`` keyed by dotted paths
    (see :func:`dotted_keys`); anything but a table as it is."""
    if isinstance(table, dict) and "noise" in table:
        return {**table, "noise": dotted_keys(table["noise"])}
    return table


class ProjectConfig(msgspec.Struct, frozen=True):
    """``[tool.beatlog]`` of a project's ``pyproject.toml``."""

    renames: dict[str, str] = {}
    """Behavior renames that hold for every spec of the project (old name -> new name)."""
    field_renames: dict[str, str] = {}
    """Robot-state fields renamed since recordings, for every spec (old name -> new name,
    dotted paths for fields of nested structs)."""
    field_conversions: dict[str, str] = {}
    """Robot-state fields retyped since recordings, for every spec: the field (its
    current name) -> the ``module:function`` that converts a recorded value."""
    systems: list[str] = []
    """The ``module:factory`` references a log may name for replay without ``--system``."""
    invariants: list[str] = []
    """The invariants every spec of the project is checked with, as ``module:attribute``
    references (a spec's own come on top; :mod:`beatlog.model.invariant`)."""
    max_open_loop_share: Annotated[float, msgspec.Meta(ge=0, le=1)] | None = None
    """The largest share of a DTC's cycles (0 to 1) that its approved baseline may run
    open loop; a DTC past it makes ``beatlog test`` fail, naming it to re-record."""
    max_open_loop_dtcs: Annotated[int, msgspec.Meta(ge=0)] | None = None
    """How many DTCs may run open loop; more make ``beatlog test`` fail, naming the
    sessions to re-record first."""
    variants: VariantsConfig | None = None
    """The variants every DTC of the project runs, and what they perturb
    (``[tool.beatlog.variants]``); a spec's ``[variants]`` comes on top."""


def project_config(folder: Path) -> ProjectConfig:
    """The configuration of the project ``folder`` belongs to (the nearest folder at or
    above it with a ``pyproject.toml``); empty when there is none. A file read before is
    read again only once it changed.

    :raises beatlog.errors.SpecError: the ``pyproject.toml`` cannot be read or its
        ``[tool.beatlog]`` table is malformed.
    """
    root = project_root(folder)
    if root is None:
        return ProjectConfig()
    path = root / "pyproject.toml"
    try:
        stat = path.stat()
    except OSError as exc:
        raise SpecError(path, f"cannot read: {exc.strerror}") from None
    return _read(path, stat.st_mtime_ns, stat.st_size)


@functools.lru_cache(maxsize=16)
def _read(path: Path, _mtime_ns: int, _size: int) -> ProjectConfig:
    """``path``'s configuration; the file's time and size key the cache."""
    try:
        data: dict[str, Any] = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise SpecError(path, f"cannot read: {exc}") from None
    section = data.get("tool", {}).get("beatlog", {})
    if isinstance(section, dict):
        if (problem := keys_problem(section, ProjectConfig, prefix="tool.beatlog.")) is not None:
            raise SpecError(path, problem)
        section = {
            key: dotted_keys(value)
            if key in _FIELD_TABLES
            else variants_table(value)
            if key == "variants"
            else value
            for key, value in section.items()
        }
    try:
        config = msgspec.convert(section, ProjectConfig)
    except msgspec.ValidationError as exc:
        raise SpecError(path, explain_validation(str(exc), prefix="tool.beatlog.")) from None
    check_one_to_one(path, "tool.beatlog.renames", config.renames)
    check_one_to_one(path, "tool.beatlog.field_renames", config.field_renames)
    check_conversions(path, "tool.beatlog.field_conversions", config.field_conversions)
    check_references(path, "tool.beatlog.invariants", config.invariants)
    return config


def vouched_system(log: str | Path, recorded: str, *, project: Path) -> str:
    """The system reference ``log`` records, once the project at ``project`` vouches for
    it by listing it under ``[tool.beatlog] systems``.

    :raises beatlog.errors.SystemLoadError: the log records no system, or one the
        project does not list; the message says how to name one.
    """
    if not recorded:
        raise SystemLoadError(
            f"{log}: records no system; name one as module:factory "
            "(--system, or system = in the spec)"
        )
    project = project.resolve()
    if recorded in project_config(project).systems:
        return recorded
    shown = recorded if len(recorded) <= _SHOWN else recorded[:_SHOWN] + "…"
    root = project_root(project)
    where = "a pyproject.toml" if root is None else str(root / "pyproject.toml")
    raise SystemLoadError(
        f"{log}: records the system {shown!r}, which this project does not vouch for; "
        f"name it (--system, or system = in the spec) or list it under "
        f"[tool.beatlog] systems in {where}"
    )


def check_one_to_one(path: Path, key: str, renames: Mapping[str, str]) -> None:
    """Refuse renames that map two old names to one new name."""
    problem = one_to_one_problem(renames)
    if problem is not None:
        raise SpecError(path, f"key {key!r}: {problem}")


def check_conversions(path: Path, key: str, conversions: Mapping[str, str]) -> None:
    """Refuse a field conversion that is no ``module:function`` reference."""
    for name, reference in conversions.items():
        if ":" not in reference:
            raise SpecError(
                path, f"key '{key}.{name}': expected module:function, got {reference!r}"
            )


def check_references(path: Path, key: str, references: list[str]) -> None:
    """Refuse an invariant that is no ``module:attribute`` reference."""
    for index, reference in enumerate(references):
        module, _, attribute = reference.partition(":")
        if not (module and attribute):
            raise SpecError(
                path, f"key '{key}[{index}]': expected module:attribute, got {reference!r}"
            )


def one_to_one_problem(renames: Mapping[str, str]) -> str | None:
    """Two old names renamed to one new name, if renames do that."""
    seen: dict[str, str] = {}
    for old, new in renames.items():
        if new in seen:
            return f"{seen[new]!r} and {old!r} are both renamed to {new!r}"
        seen[new] = old
    return None


def dotted_keys(table: Any) -> Any:
    """A TOML table keyed by robot-state fields with its nested tables flattened into
    dotted paths: TOML reads ``pose.x = "pose.px"`` as ``{"pose": {"x": "pose.px"}}``,
    which means the field ``pose.x``. Anything but a table is returned as it is."""
    if not isinstance(table, dict):
        return table
    flat: dict[str, Any] = {}
    for key, value in table.items():
        if isinstance(value, dict) and value:
            flat.update((f"{key}.{inner}", leaf) for inner, leaf in dotted_keys(value).items())
        else:
            flat[key] = value
    return flat


def keys_problem(
    data: Mapping[str, Any], table: type[msgspec.Struct], prefix: str = ""
) -> str | None:
    """Every key of ``data`` unknown to ``table`` (with the key it may mean) and every
    one ``table`` requires that is missing, at once; each named with ``prefix``."""
    fields = msgspec.structs.fields(table)
    known = [field.name for field in fields]
    problems = []
    for key in data:
        if key not in known:
            near = difflib.get_close_matches(key, known, n=1)
            problems.append(
                f"unknown key {prefix + key!r}"
                + (f" (did you mean {prefix + near[0]!r}?)" if near else "")
            )
    missing = [prefix + field.name for field in fields if field.required and field.name not in data]
    if missing:
        listed = ", ".join(repr(key) for key in missing)
        problems.append(f"missing key{'s' if len(missing) > 1 else ''} {listed}")
    return "; ".join(problems) or None


TOML_TYPES = {
    "str": "a string",
    "int": "an integer",
    "float": "a number",
    "bool": "true or false",
    "array": "a list",
    "object": "a table",
}
"""msgspec's names of types, in the words of the TOML a user wrote."""


def explain_validation(message: str, prefix: str = "") -> str:
    """Turn msgspec's ``... - at `$.key[0]` `` into ``key 'key[0]': ...``, its types in
    TOML's words (``expected a table, got an integer``)."""
    match = re.fullmatch(r"(.*) - at `\$\.?(.*)`", message)
    if match:
        problem, key = match.groups()
        problem = problem.replace(" | null`", "`")  # an optional key: TOML has no null
        problem = re.sub(r"`(\w+)`", lambda type_: TOML_TYPES.get(type_[1], type_[0]), problem)
        key = key.replace("[...]", ".*")  # a value of a table
        return f"key {prefix + key!r}: {problem[0].lower()}{problem[1:]}"
    unknown = re.fullmatch(r"Object contains unknown field `(.*)`", message)
    if unknown:
        return f"unknown key {prefix + unknown.group(1)!r}"
    missing = re.fullmatch(r"Object missing required field `(.*)`", message)
    if missing:
        return f"missing key {prefix + missing.group(1)!r}"
    return message
