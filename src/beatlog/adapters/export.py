"""Export a session log for viewers and for analysis; only the log is read, no code runs
(unless a system is given to replay, for its first divergence). The output's suffix
names the format (``.mcap``, ``.parquet``, ``.csv``) unless one is asked for, and a
format the suffix contradicts is refused before anything is written.

**MCAP for Foxglove and Lichtblick.** A ``.beatlog`` is MCAP, but its msgpack payloads
are not an encoding those viewers decode. The export writes message encoding ``json``
and schema encoding ``jsonschema``, one schema per channel (behavior channels share
one), each message stamped with the recording's start (the header's ``start_time_ns``,
Unix ns) plus the robot time at the end of its cycle, and sequence-numbered with its
cycle; a ``beatlog`` metadata record holds the header, says so, and says how the log
ends (``complete`` or ``truncated at cycle N: ...``). Both viewers read a JSON schema
with one parser (``parseJsonSchema`` in their ``mcap-support`` package), which takes
only an object with ``properties`` whose every field has one ``type``: boolean, string
(base64 with ``contentEncoding``), number, integer, an object with its own
``properties`` or an array of one of those.
Every schema here keeps to that, so every field is a typed field in the viewers'
message paths and plots, and every message validates against its schema:

- ``/robot_state``: RS_t, every cycle, as the header's robot-state schema declares
  it, every ``$ref`` inlined: numbers, integers, booleans and strings (an enum of
  strings or integers is one too), nested structs as objects, lists of those as
  arrays. What the viewers cannot type (a map, tuple, union, a list of lists or of
  nullables, a type inside itself) is a string of its JSON text. A null is left out.
  A log whose header declares no object is typed from a read of its fields.
- ``/behaviors/<name>``: a behavior's state after cycle 0, then after each change,
  as a string: the state as it prints (``idle``), or its JSON text if it is no
  string (``3``, ``true``). Before its first change a behavior's state is the
  ``before`` of that change; a behavior that never changes in the log has no known
  state and shows ``null``.
- ``/state_changes``: one Foxglove ``foxglove.Log`` message per change (INFO,
  ``avoid: idle -> turning``, the behavior as ``name``), for the Log panel. The
  schema is Foxglove's except ``level``: an integer here, not a ``oneOf`` of the
  level constants, which Lichtblick's parser refuses in releases that predate its
  enum support.
- ``/outputs``: the outputs of every cycle, each output a field typed as a first read
  of the log finds it (number, integer, boolean or string); an output whose values
  are lists, maps or of mixed types is a string of JSON text.
- ``/random_numbers``: the draws of each cycle that drew any: actor and kind, value
  and params as JSON text (a numpy array draw is dtype, shape and base64 bytes).
- ``/heartbeat``: HB_t of every cycle.
- ``/samples/<sensor>``: in a log recorded with samples, each raw sample (its stamp
  and value), typed as a first read of the log finds the sensor's values: maps with
  string keys as objects, lists as arrays, what the viewers cannot type as JSON text.
- ``/tf``: where the robot state has number fields ``x``, ``y`` and ``heading``,
  ``yaw`` or ``theta`` (radians, counter-clockwise; ``z`` too if it has one), at its
  top level or in an object field ``pose``, the robot's pose each cycle as Foxglove's
  ``foxglove.FrameTransform`` from ``odom`` to ``base_link``, for the 3D panel (none
  in a cycle where one of them is NaN or ±inf).
- ``/divergence``: with a system, one message at its first divergence from the log
  (``behavior`` empty when it concerns none; expected and actual state changes as
  lists of behavior, before and after strings).

JSON holds no NaN or infinity, and a plot's number field cannot hold a string: a
float field that is NaN or ±inf is left out of that message (a gap in a plot) and
listed in the message's ``non_finite`` string array as ``path=value``
(``distance=NaN``, ``pose.x=Infinity``, ``outputs.speed=-Infinity``). An array of
numbers that holds one anywhere in the log is, in that export, an array of the
numbers' texts (``["0.5", "NaN"]``): no schema can be an array of numbers for the
viewers and allow a null or a string in it for a validator. Inside JSON text they
are the strings ``"NaN"``, ``"Infinity"`` and ``"-Infinity"``, and bytes are base64.

**Tables** (Parquet, which needs the ``export`` extra, or CSV): one row per cycle
with ``cycle``, ``time_ns``, ``heartbeat_ns`` (robot time), one column per
robot-state field (``a.b`` for a nested struct's field), ``behavior.<name>`` (its
state after the cycle, as on the behavior channels; null while unknown),
``out.<name>`` and ``draws`` (how many random numbers the cycle drew). The columns'
types come from the header's robot-state schema and the behavior catalogue, so every
log of a system has the same Parquet schema, whatever its values: a number is a
double, an integer an int64, a list of those a list, a behavior's state a string; a
map, union or list of structs is JSON text. Outputs are typed from a read of the log
(numbers as doubles; lists, maps and mixed types as JSON text), and a log whose
header declares no object has its fields typed so too. The Parquet metadata holds
the header and how the log ends, as the MCAP's does (keys ``beatlog.<name>``).
Floats stay floats: Parquet keeps NaN and ±inf, CSV writes ``nan``, ``inf`` and
``-inf``; in CSV a list or map is its JSON text.
"""

from __future__ import annotations

import base64
import csv
import json
import math
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from enum import Enum, StrEnum
from pathlib import Path
from typing import Any, NamedTuple

import msgspec
from mcap.writer import Writer

from beatlog._version import __version__
from beatlog.adapters import foxglove
from beatlog.errors import CorruptLogError, ExportError
from beatlog.log.format import (
    DECODE_ERRORS,
    EMPTY_LIST,
    Draw,
    SessionHeader,
    StateChangeRecord,
)
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.model.behavior import BehaviorState, System
from beatlog.model.inbox import Sample
from beatlog.replay.judge import replay
from beatlog.replay.verdict import Divergence, DivergenceKind, ReplayResult, StateChange

__all__ = ["ExportFormat", "ExportResult", "export", "export_format"]


class ExportFormat(StrEnum):
    """What ``beatlog export`` writes."""

    MCAP = "mcap"
    """MCAP with JSON messages and JSON schemas, for Foxglove and Lichtblick."""
    PARQUET = "parquet"
    """One row per cycle in Parquet (needs pyarrow: ``pip install "beatlog[export]"``)."""
    CSV = "csv"
    """One row per cycle as comma-separated text."""

    @property
    def suffix(self) -> str:
        """The suffix of a file in this format: ``.mcap``, ``.parquet`` or ``.csv``."""
        return f".{self.value}"


def export_format(output: str | Path, format: ExportFormat | str | None = None) -> ExportFormat:
    """The format ``output`` is written in: ``format``, or the one its suffix names
    (``.mcap``, ``.parquet`` or ``.csv``) when ``format`` is None.

    :raises beatlog.errors.ExportError: ``format`` names no format, the suffix names
        another one, or no format is given and the suffix names none.
    """
    suffix = Path(output).suffix.lower()
    named = next((chosen for chosen in ExportFormat if chosen.suffix == suffix), None)
    if format is None:
        if named is None:
            given = f"suffix {suffix}" if suffix else "no suffix"
            known = ", ".join(chosen.suffix for chosen in ExportFormat)
            raise ExportError(
                f"{output}: an export is written as {known}, not {given}; or name the format"
            )
        return named
    try:
        chosen = ExportFormat(format)
    except ValueError:
        choices = ", ".join(ExportFormat)
        raise ExportError(f"cannot export as {format!r}; choose one of {choices}") from None
    if named is not None and named is not chosen:
        raise ExportError(
            f"{output}: a {suffix} file is not written as {chosen}; "
            f"name it {chosen.suffix} or export as {named}"
        )
    return chosen


@dataclass(frozen=True)
class ExportResult:
    """What an export wrote."""

    log: Path
    output: Path
    format: ExportFormat
    cycles: int
    status: LogStatus
    """How the log ended; a truncated log is exported up to its last complete cycle."""
    replayed: bool
    """Whether a system was replayed for the divergence."""
    divergence: Divergence | None
    """The replay's first divergence, when a system was replayed and it diverged."""
    url: str | None = None
    """The URL of the log, when it lay behind one: ``log`` is then the copy exported,
    which is gone."""

    @property
    def log_name(self) -> str:
        """The log as messages name it: its URL, or its path."""
        return str(self.log) if self.url is None else self.url

    def describe(self) -> str:
        """One line for people: what was written, how the log ended, what replay found."""
        line = f"exported {self.cycles} cycles of {self.log_name} to {self.output} ({self.format})"
        if not self.status.complete:
            line += f"; the log is {self.status.describe()}"
        if self.divergence is not None:
            line += f"; first divergence at cycle {self.divergence.cycle} ({self.divergence.kind})"
        elif self.replayed:
            line += "; the replay passed"
        return line


def export(
    log: str | Path,
    output: str | Path,
    *,
    format: ExportFormat | str | None = None,
    system: System | str | None = None,
) -> ExportResult:
    """Write ``log`` to ``output`` in ``format`` (by default the one the output's suffix
    names, see :func:`export_format`); with ``system`` (MCAP only), replay the log
    against it and add its first divergence.

    The output is written next to its final place and moved there when complete, so
    an export that fails (a damaged log, a full disk) leaves no partial file.

    :raises beatlog.errors.LogError: the log cannot be read (or does not fit ``system``).
    :raises beatlog.errors.ExportError: the format does not fit the output's suffix, the
        output cannot be written, Parquet is asked for without pyarrow, or a system is
        given for a table.
    """
    log, output = Path(log), Path(output)
    chosen = export_format(output, format)
    if system is not None and chosen is not ExportFormat.MCAP:
        raise ExportError(f"a replay's divergence is exported to MCAP only, not {chosen}")
    if chosen is ExportFormat.PARQUET:
        _pyarrow()
    if output.exists() and log.exists() and output.samefile(log):
        raise ExportError(f"{output}: is the session log being exported; name another file")
    replayed = (
        None
        if system is None
        else replay(log, system, allow_truncated=True, allow_empty=True, explain=False)
    )
    first = _first_read(log)
    with SessionLogReader(log) as reader, _replacing(output) as part:
        session = _Session(log, reader.header, _decoded_cycles(reader), first)
        if chosen is ExportFormat.MCAP:
            _write_mcap(part, session, replayed)
        else:
            _write_table(part, session, chosen)
        status = reader.status
    return ExportResult(
        log=log,
        output=output,
        format=chosen,
        cycles=status.cycles,
        status=status,
        replayed=replayed is not None,
        divergence=None if replayed is None else replayed.divergence,
    )


class _Cycle(NamedTuple):
    """One cycle of the log, decoded, with behaviors and actors by name."""

    number: int
    time_ns: int
    heartbeat_ns: int
    robot_state: dict[str, Any]
    changes: list[StateChange]
    draws: list[tuple[str, Draw]]
    outputs: dict[str, Any]
    samples: list[Sample]


class _FirstRead(NamedTuple):
    """What a first pass over the log finds."""

    initial: Mapping[str, BehaviorState]
    """Each catalogue behavior's state at the start: the ``before`` of its first change
    (None for a behavior that never changes in the log)."""
    output_types: Mapping[str, str | None]
    """Each output's JSON-schema type over the whole log (see ``_add_types``)."""
    status: LogStatus
    """How the log ends."""
    robot_state: _Field
    """The robot state's fields: as the header declares them, else as the log holds them."""
    non_finite_arrays: frozenset[str]
    """The robot-state arrays of numbers that hold a NaN or ±inf somewhere in the log, as
    paths (``ranges``, ``pose.cov``, ``blips[].values``)."""
    samples: Mapping[str, _Field | None]
    """Each sensor's sample values as the log holds them (None: only nulls)."""


class _Session(NamedTuple):
    """What the writers read: the log, its header, its cycles decoded one by one, and
    what a first read of the log found."""

    log: Path
    header: SessionHeader
    cycles: Iterator[_Cycle]
    first: _FirstRead


def _decoded_cycles(reader: SessionLogReader) -> Iterator[_Cycle]:
    names = reader.header.behaviors
    decode_map = msgspec.msgpack.Decoder(dict[str, Any]).decode
    decode_changes = msgspec.msgpack.Decoder(list[StateChangeRecord]).decode
    decode_draws = msgspec.msgpack.Decoder(list[Draw]).decode
    decode_samples = msgspec.msgpack.Decoder(list[Sample]).decode
    time_ns = 0
    for number, record in enumerate(reader.cycles()):
        time_ns += record.heartbeat_ns
        try:
            state = decode_map(record.robot_state)
            changes = (
                [] if record.state_changes == EMPTY_LIST else decode_changes(record.state_changes)
            )
            draws = (
                [] if record.random_numbers == EMPTY_LIST else decode_draws(record.random_numbers)
            )
            outputs = decode_map(record.outputs)
            samples = [] if record.samples == EMPTY_LIST else decode_samples(record.samples)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(reader.path, f"damaged cycle {number}: {exc}") from None
        yield _Cycle(
            number,
            time_ns,
            record.heartbeat_ns,
            state,
            [StateChange(_name(names, index), before, after) for index, before, after in changes],
            [(_name(names, draw.actor), draw) for draw in draws],
            outputs,
            samples,
        )


def _name(catalogue: Sequence[str], index: int) -> str:
    if index < 0:
        return "system"
    return catalogue[index] if index < len(catalogue) else f"#{index}"


def _first_read(log: Path) -> _FirstRead:
    with SessionLogReader(log) as reader:
        header = reader.header
        states: dict[str, BehaviorState] = header.initial_states_by_name()
        output_types: dict[str, str | None] = {}
        declared = _declared_object(header.robot_state_schema, log)
        state_types: dict[str, str | None] = {}
        scan = declared is not None and _holds_number_arrays(declared)
        non_finite: set[str] = set()
        samples: dict[str, _Field | None] = {}
        for cycle in _decoded_cycles(reader):
            for change in cycle.changes:
                states.setdefault(change.behavior, change.before)
            _add_types(output_types, cycle.outputs)
            if declared is None:
                _add_types(state_types, cycle.robot_state)
            elif scan:
                _find_non_finite_arrays(declared, cycle.robot_state, "", non_finite)
            for sample in cycle.samples:
                samples[sample.sensor] = _merged(
                    samples.get(sample.sensor), _inferred(sample.value, log, cycle.number)
                )
        initial = {name: states.get(name) for name in header.behaviors}
        robot_state = _typed_object(state_types) if declared is None else declared
        return _FirstRead(
            initial, output_types, reader.status, robot_state, frozenset(non_finite), samples
        )


def _states_after(states: dict[str, BehaviorState], changes: Sequence[StateChange]) -> None:
    """Apply a cycle's changes of catalogue behaviors to ``states``."""
    for change in changes:
        if change.behavior in states:
            states[change.behavior] = change.after


@contextmanager
def _replacing(output: Path) -> Iterator[Path]:
    """A file to write next to ``output``, moved over it when the block completes."""
    part = output.with_name(f".{output.name}.part")
    try:
        yield part
        part.replace(output)
    except OSError as exc:
        raise ExportError(f"{output}: cannot write: {exc.strerror or exc}") from None
    finally:
        part.unlink(missing_ok=True)


# JSON


def _jsonable(value: Any) -> Any:
    """``value`` with NaN and ±inf as strings and map keys as strings; JSON encodes the
    rest (bytes as base64)."""
    if isinstance(value, float):
        if math.isfinite(value):
            return value
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, dict):
        return {
            key if isinstance(key, str) else json.dumps(_jsonable(key)): _jsonable(item)
            for key, item in value.items()
        }
    if isinstance(value, list | tuple):
        return [_jsonable(item) for item in value]
    return value


_JSON = msgspec.json.Encoder()


def _json_text(value: Any, log: Path, where: str) -> bytes:
    try:
        return _JSON.encode(_jsonable(value))
    except (TypeError, msgspec.EncodeError, RecursionError) as exc:
        raise CorruptLogError(log, f"{where} cannot be written as JSON: {exc}") from None


def _state_text(state: BehaviorState) -> str:
    """A behavior state as a viewer shows it: a string as it is, anything else as JSON."""
    return state if isinstance(state, str) else json.dumps(state)


# MCAP: what a field is for the viewers


class _Kind(Enum):
    NUMBER = "a JSON number; NaN and ±inf are left out and listed in non_finite"
    NUMBER_TEXT = "a number in an array as its text: 0.5, NaN, Infinity, -Infinity"
    PLAIN = "an integer, boolean or string, written as it is"
    OBJECT = "an object with its own fields"
    ARRAY = "an array of numbers, number texts, integers, booleans, strings or objects"
    JSON = "a string holding the value's JSON text"


class _Field(NamedTuple):
    """A field as the viewers get it: its JSON schema and how a value is written."""

    schema: dict[str, Any]
    kind: _Kind
    fields: Mapping[str, _Field] = {}
    """An object's fields."""
    items: _Field | None = None
    """An array's items (None: not known, the log holds only empty arrays)."""


_NON_FINITE = "non_finite"
_NON_FINITE_SCHEMA = {
    "type": "array",
    "items": {"type": "string"},
    "description": "The fields left out of this message because their value is NaN or "
    "infinite, as path=value: distance=NaN, outputs.speed=-Infinity, blips[1].x=NaN.",
}
_JSON_TEXT = {
    "type": "string",
    "description": 'JSON text of the value: NaN and ±inf as the strings "NaN", "Infinity" '
    'and "-Infinity", bytes as base64.',
}
_BY_TYPE = {
    "number": _Field({"type": "number"}, _Kind.NUMBER),
    "integer": _Field({"type": "integer"}, _Kind.PLAIN),
    "boolean": _Field({"type": "boolean"}, _Kind.PLAIN),
    "string": _Field({"type": "string"}, _Kind.PLAIN),
    "json": _Field(_JSON_TEXT, _Kind.JSON),
}
_BASE64 = _Field({"type": "string", "contentEncoding": "base64"}, _Kind.PLAIN)
_NUMBER_TEXT = _Field(
    {
        "type": "string",
        "description": "A number as its text (0.5); NaN and ±inf as NaN, Infinity and -Infinity.",
    },
    _Kind.NUMBER_TEXT,
)
_NUMBERS = (_BY_TYPE["number"], _BY_TYPE["integer"], _NUMBER_TEXT)
_ARRAY_ITEMS = frozenset({_Kind.NUMBER, _Kind.NUMBER_TEXT, _Kind.PLAIN, _Kind.OBJECT})
_GAP = object()
"""What a value left out of its message is written as."""


def _object_field(fields: Mapping[str, _Field]) -> _Field:
    properties = {name: field.schema for name, field in fields.items()}
    return _Field({"type": "object", "properties": properties}, _Kind.OBJECT, fields)


def _array_field(items: _Field | None) -> _Field:
    """An array of ``items`` (of numbers while they are not known), or JSON text if the
    viewers cannot type an array of them."""
    if items is None:
        return _Field({"type": "array", "items": {"type": "number"}}, _Kind.ARRAY)
    if items.kind in _ARRAY_ITEMS and items is not _BASE64:
        return _Field({"type": "array", "items": items.schema}, _Kind.ARRAY, items=items)
    return _BY_TYPE["json"]


def _written(field: _Field, value: Any, path: str, non_finite: list[str]) -> Any:
    """``value`` as ``field`` declares it, or ``_GAP`` for a null, NaN or ±inf (listed in
    ``non_finite`` as ``path=value``)."""
    if value is None:
        return _GAP
    kind = field.kind
    if kind is _Kind.NUMBER:
        if isinstance(value, float) and not math.isfinite(value):
            non_finite.append(f"{path}={json.dumps(value)}")
            return _GAP
        return value
    if kind is _Kind.OBJECT:
        return _written_object(field.fields, value, f"{path}.", non_finite)
    if kind is _Kind.ARRAY:
        items = field.items
        if items is None or items.kind is _Kind.NUMBER:
            return value  # finite: the first read made an array holding NaN or ±inf texts
        return [_written(items, item, f"{path}[{i}]", non_finite) for i, item in enumerate(value)]
    if kind is _Kind.NUMBER_TEXT:
        return json.dumps(value) if isinstance(value, int | float) else _json_value(value)
    if kind is _Kind.JSON:
        return _json_value(value)
    return value


def _json_value(value: Any) -> str:
    return _JSON.encode(_jsonable(value)).decode()


def _written_object(
    fields: Mapping[str, _Field], value: Mapping[str, Any], prefix: str, non_finite: list[str]
) -> dict[str, Any]:
    """The declared fields of ``value`` (a field the schema lacks is left out)."""
    written = {}
    for name, field in fields.items():
        if name in value:
            item = _written(field, value[name], f"{prefix}{name}", non_finite)
            if item is not _GAP:
                written[name] = item
    return written


def _type_of(value: Any) -> str:
    """The JSON-schema type of a value read from the log (``json`` for lists, maps, bytes)."""
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "number"
    return "string" if isinstance(value, str) else "json"


def _add_types(types: dict[str, str | None], values: Mapping[str, Any]) -> None:
    """Merge the types of ``values`` into ``types``: integers and floats make a number,
    any other mix is JSON text; a field that is always null stays None."""
    for name, value in values.items():
        seen = types.get(name)
        if value is None:
            types.setdefault(name, None)
        elif seen is None:
            types[name] = _type_of(value)
        elif seen != "json":
            kind = _type_of(value)
            if kind != seen:
                types[name] = "number" if {kind, seen} == {"integer", "number"} else "json"


def _typed_object(types: Mapping[str, str | None]) -> _Field:
    """An object of the fields a first read of the log found, typed as it found them."""
    return _object_field({name: _BY_TYPE[kind or "json"] for name, kind in types.items()})


def _path(within: str, name: str) -> str:
    return f"{within}.{name}" if within else name


def _holds_number_arrays(field: _Field) -> bool:
    if field.kind is _Kind.OBJECT:
        return any(_holds_number_arrays(inner) for inner in field.fields.values())
    items = field.items
    return items is not None and (items.kind is _Kind.NUMBER or _holds_number_arrays(items))


def _find_non_finite_arrays(field: _Field, value: Any, path: str, found: set[str]) -> None:
    """Add to ``found`` the path of each array of numbers in ``value`` holding a NaN or ±inf."""
    if field.kind is _Kind.OBJECT and isinstance(value, dict):
        for name, inner in field.fields.items():
            if name in value:
                _find_non_finite_arrays(inner, value[name], _path(path, name), found)
    elif field.items is not None and isinstance(value, list):
        if field.items.kind is _Kind.NUMBER:
            if any(isinstance(item, float) and not math.isfinite(item) for item in value):
                found.add(path)
        elif field.items.kind is _Kind.OBJECT:
            for item in value:
                _find_non_finite_arrays(field.items, item, f"{path}[]", found)


def _numbers_as_text(field: _Field, paths: frozenset[str], path: str = "") -> _Field:
    """``field`` with each array of numbers at one of ``paths`` made an array of their
    texts, which JSON can hold with NaN and ±inf in it."""
    if not paths:
        return field
    if field.kind is _Kind.OBJECT:
        return _object_field(
            {
                name: _numbers_as_text(inner, paths, _path(path, name))
                for name, inner in field.fields.items()
            }
        )
    items = field.items
    if items is not None and items.kind is _Kind.NUMBER and path in paths:
        return _array_field(_NUMBER_TEXT)
    if items is not None and items.kind is _Kind.OBJECT:
        return _array_field(_numbers_as_text(items, paths, f"{path}[]"))
    return field


def _inferred(value: Any, log: Path, cycle: int) -> _Field | None:
    """The field that ``value``, read from the log, is for a channel typed from the log's
    values (None for a null); see :func:`_value_field`."""
    try:
        return _value_field(value, in_array=False)
    except RecursionError:
        raise _too_deep(log, cycle) from None


def _too_deep(log: Path, cycle: int) -> CorruptLogError:
    return CorruptLogError(log, f"a sample of cycle {cycle} is nested too deep")


def _value_field(value: Any, *, in_array: bool) -> _Field | None:
    """A null is None; a map with string keys an object, a list an array (of number texts
    if one of its numbers is NaN or ±inf); what the viewers cannot type is JSON text."""
    if value is None:
        return None
    if isinstance(value, float) and in_array and not math.isfinite(value):
        return _NUMBER_TEXT
    if isinstance(value, bytes):
        return _BASE64
    if isinstance(value, dict):
        if not all(isinstance(key, str) for key in value):
            return _BY_TYPE["json"]
        fields = {}
        for name, item in value.items():
            inner = _value_field(item, in_array=False)
            if inner is not None:
                fields[name] = inner
        return _object_field(fields)
    if isinstance(value, list):
        items: _Field | None = None
        for item in value:
            inner = _value_field(item, in_array=True)
            if inner is None:
                return _BY_TYPE["json"]  # an array of nullables
            items = _merged(items, inner)
        return _array_field(items)
    return _BY_TYPE[_type_of(value)]


def _merged(seen: _Field | None, field: _Field | None) -> _Field | None:
    """One field for the values of two: objects merge their fields, arrays their items,
    integers and numbers make numbers (number texts if either is); any other mix is
    JSON text."""
    if seen is None or seen == field:
        return field
    if field is None:
        return seen
    if seen.kind is field.kind is _Kind.OBJECT:
        fields = dict(seen.fields)
        for name, inner in field.fields.items():
            fields[name] = _merged(fields.get(name), inner) or inner
        return _object_field(fields)
    if seen.kind is field.kind is _Kind.ARRAY:
        return _array_field(_merged(seen.items, field.items))
    if seen in _NUMBERS and field in _NUMBERS:
        return _NUMBER_TEXT if _NUMBER_TEXT in (seen, field) else _BY_TYPE["number"]
    return _BY_TYPE["json"]


_MAX_SCHEMA_NODES = 100_000
"""A robot-state schema inlined beyond this many nodes is refused (a hostile header
could otherwise expand exponentially)."""


def _declared_object(schema: Mapping[str, Any], log: Path) -> _Field | None:
    """The header's robot-state schema as the viewers take it (None if it describes no
    object with properties): every ``$ref`` to ``#/$defs/...`` inlined; a number,
    integer, boolean or string as that type (an enum of strings or of integers too, a
    nullable one too: a null is left out); an object with properties and an array of
    those with their own schemas; anything else (a map, tuple, union, an array of
    arrays or of nullables, a type within itself) as JSON text."""
    definitions = schema.get("$defs")
    defs = definitions if isinstance(definitions, dict) else {}
    nodes = 0

    def field(node: Any, within: tuple[str, ...], nullable: bool) -> _Field:
        nonlocal nodes
        nodes += 1
        if nodes > _MAX_SCHEMA_NODES:
            raise CorruptLogError(
                log, f"the robot-state schema inlines to more than {_MAX_SCHEMA_NODES} nodes"
            )
        if not isinstance(node, dict):
            return _BY_TYPE["json"]
        reference = node.get("$ref")
        if reference is not None:
            name = reference.removeprefix("#/$defs/") if isinstance(reference, str) else ""
            if name == reference or name not in defs:
                raise CorruptLogError(
                    log, f"the robot-state schema refers to {reference!r}, which it lacks"
                )
            target = defs[name]
            if name in within or not isinstance(target, dict):
                return _BY_TYPE["json"]
            rest = {key: value for key, value in node.items() if key != "$ref"}
            return field({**rest, **target}, (*within, name), nullable)
        kind = node.get("type")
        alternatives = node.get("anyOf", node.get("oneOf"))
        if isinstance(alternatives, list):
            others = [option for option in alternatives if option != {"type": "null"}]
            if not (nullable and len(others) == 1 == len(alternatives) - 1):
                return _BY_TYPE["json"]
            return field(others[0], within, nullable=False)
        if isinstance(kind, list):
            others = [option for option in kind if option != "null"]
            kind = others[0] if nullable and len(others) == 1 == len(kind) - 1 else "json"
        enum = node.get("enum")
        if kind is None and isinstance(enum, list) and enum:
            kinds = {_type_of(value) for value in enum}
            kind = kinds.pop() if len(kinds) == 1 else "json"
        properties = node.get("properties")
        items = node.get("items")
        if kind == "object" and isinstance(properties, dict):
            return _object_field(
                {name: field(value, within, nullable=True) for name, value in properties.items()}
            )
        if kind == "array" and isinstance(items, dict) and "prefixItems" not in node:
            return _array_field(field(items, within, nullable=False))
        if kind == "string" and node.get("contentEncoding") == "base64":
            return _BASE64
        return _BY_TYPE.get(kind if isinstance(kind, str) else "json", _BY_TYPE["json"])

    try:
        declared = field(dict(schema), (), nullable=False)
    except RecursionError:
        raise CorruptLogError(log, "the robot-state schema is nested too deep") from None
    return declared if declared.kind is _Kind.OBJECT else None


# MCAP: schemas

_DIALECT = "https://json-schema.org/draft/2020-12/schema"
_CYCLE = {"type": "integer", "minimum": 0, "description": "The cycle (heartbeat) t."}
_STATE = {
    "type": "string",
    "description": "The state as it prints (idle), or its JSON text if it is no string "
    "(3, true, null).",
}
_CHANGE = {
    "type": "object",
    "properties": {"behavior": {"type": "string"}, "before": _STATE, "after": _STATE},
    "required": ["behavior", "before", "after"],
    "additionalProperties": False,
}


def _record_schema(
    title: str, description: str, optional: Sequence[str] = (), **properties: Mapping[str, Any]
) -> dict[str, Any]:
    return {
        "$schema": _DIALECT,
        "title": title,
        "description": description,
        "type": "object",
        "properties": {"cycle": _CYCLE, **properties},
        "required": ["cycle", *(name for name in properties if name not in optional)],
        "additionalProperties": False,
    }


_HEARTBEAT_SCHEMA = _record_schema(
    "beatlog.Heartbeat",
    "The heartbeat interval HB_t that ended this cycle.",
    interval_ns={"type": "integer", "minimum": 0},
    interval_ms={"type": "number", "minimum": 0},
)
_BEHAVIOR_SCHEMA = _record_schema(
    "beatlog.BehaviorState",
    'A behavior\'s state after this cycle; "null" when the log never shows it (it never changes).',
    state=_STATE,
)
_RANDOM_SCHEMA = _record_schema(
    "beatlog.RandomNumbers",
    "The random numbers drawn in this cycle, in draw order (RN_t).",
    draws={
        "type": "array",
        "items": {
            "type": "object",
            "properties": {
                "actor": {"type": "string", "description": "The behavior, or 'system'."},
                "kind": {"type": "string"},
                "value": _JSON_TEXT,
                "params": _JSON_TEXT,
            },
            "required": ["actor", "kind", "value", "params"],
            "additionalProperties": False,
        },
    },
)
_DIVERGENCE_SCHEMA = _record_schema(
    "beatlog.Divergence",
    "The first cycle where replaying the log against a system differed from it.",
    kind={"type": "string", "enum": list(DivergenceKind)},
    message={"type": "string"},
    behavior={"type": "string", "description": "The behavior it concerns; empty if none."},
    expected={"type": "array", "items": _CHANGE},
    actual={"type": "array", "items": _CHANGE},
    reproduce={"type": "string"},
)
_POSE_TOPIC = "/tf"
_POSE_FRAMES = ("odom", "base_link")
"""The frames of the robot's pose: the fixed frame it moves in, and the robot's own."""


def _robot_state_schema(title: str, robot_state: _Field) -> dict[str, Any]:
    return {
        "$schema": _DIALECT,
        "title": title,
        **robot_state.schema,
        "properties": {**robot_state.schema["properties"], _NON_FINITE: _NON_FINITE_SCHEMA},
    }


def _sample_schema(sensor: str, value: _Field) -> dict[str, Any]:
    return _record_schema(
        "beatlog.Sample",
        f"A raw sample of sensor {sensor!r} folded into RS_t in this cycle, typed as a first "
        "read of the log found its values (a null is left out).",
        optional=["value", _NON_FINITE],
        stamp_ns={"type": "integer", "description": "The sample's own time stamp (ns)."},
        value=value.schema,
        non_finite=_NON_FINITE_SCHEMA,
    )


def _outputs_schema(outputs: _Field) -> dict[str, Any]:
    return _record_schema(
        "beatlog.Outputs",
        "What the behaviors output in this cycle, e.g. motor commands, typed as a first "
        "read of the log found them (lists, maps and mixed types as JSON text).",
        optional=[_NON_FINITE],
        outputs=outputs.schema,
        non_finite=_NON_FINITE_SCHEMA,
    )


# MCAP: messages


class _McapChannels:
    """Registers the export's schemas and channels and writes JSON messages to them."""

    def __init__(self, writer: Writer, log: Path, start_ns: int) -> None:
        self._writer = writer
        self._log = log
        self._start_ns = start_ns
        self._schemas: dict[str, int] = {}

    def add(self, topic: str, name: str, schema: Mapping[str, Any]) -> int:
        if name not in self._schemas:
            data = _json_text(schema, self._log, f"the schema of {topic}")
            self._schemas[name] = self._writer.register_schema(name, "jsonschema", data)
        return int(self._writer.register_channel(topic, "json", self._schemas[name]))

    def stamp(self, cycle: _Cycle) -> int:
        """The log time of a cycle's messages: the recording's start plus its robot time."""
        time_ns = self._start_ns + cycle.time_ns
        if time_ns > _MAX_LOG_TIME_NS:
            raise CorruptLogError(
                self._log, f"cycle {cycle.number} ends past the latest time MCAP can stamp"
            )
        return time_ns

    def write(self, channel: int, cycle: _Cycle, message: Any, what: str) -> None:
        """Write ``message`` stamped with the cycle's log time and numbered with the cycle."""
        data = _json_text(message, self._log, f"the {what} of cycle {cycle.number}")
        time_ns = self.stamp(cycle)
        self._writer.add_message(channel, time_ns, data, time_ns, sequence=cycle.number)


_MAX_LOG_TIME_NS = 2**64 - 1
_LOG_TIME = (
    "each message is stamped with the recording's start (start_time_ns, Unix ns) plus "
    "the robot time at the end of its cycle"
)


def _log_metadata(session: _Session) -> dict[str, str]:
    """What an export says of its log, as text: its header, and how and where it ends."""
    header, status = session.header, session.first.status
    return {
        "log": session.log.name,
        "format_version": str(header.format_version),
        "robot_id": header.robot_id,
        "software_version": header.software_version,
        "system": header.system,
        "robot_state_type": header.robot_state_type,
        "period_ns": str(header.period_ns),
        "start_time_ns": str(header.start_time_ns),
        "cycles": str(status.cycles),
        "complete": "true" if status.complete else "false",
        "status": status.describe(),
    }


def _sample_topic(sensor: str) -> str:
    return f"/samples/{sensor.removeprefix('/')}"


class _Pose(NamedTuple):
    """Where the robot state holds the robot's pose: the object field holding ``x``, ``y``
    and the others (None: the robot state itself), the yaw's name, and whether it has a
    ``z`` (else 0)."""

    within: str | None
    yaw: str
    has_z: bool

    def of(self, state: Mapping[str, Any]) -> tuple[tuple[float, float, float], float] | None:
        """The position and yaw in ``state``; None when one is missing, NaN or infinite."""
        holder = state if self.within is None else state.get(self.within)
        if not isinstance(holder, dict):
            return None
        names = ("x", "y", self.yaw, "z") if self.has_z else ("x", "y", self.yaw)
        values = [holder.get(name) for name in names]
        numbers = [float(v) for v in values if isinstance(v, float | int) and math.isfinite(v)]
        if len(numbers) < len(names):
            return None
        x, y, yaw, *z = numbers
        return (x, y, z[0] if z else 0.0), yaw


_YAW_NAMES = ("heading", "yaw", "theta")


def _pose_of(robot_state: _Field) -> _Pose | None:
    """The robot's pose: number fields ``x``, ``y`` (``z`` if there is one) and ``heading``,
    ``yaw`` or ``theta`` in the robot state, or else in its object field ``pose``."""
    pose = robot_state.fields.get("pose")
    holders = {None: robot_state.fields, "pose": {} if pose is None else pose.fields}
    for within, fields in holders.items():
        numbers = {name for name, field in fields.items() if field.kind is _Kind.NUMBER}
        yaw = next((name for name in _YAW_NAMES if name in numbers), None)
        if yaw is not None and {"x", "y"} <= numbers:
            return _Pose(within, yaw, "z" in numbers)
    return None


def _robot_state_field(session: _Session) -> _Field:
    """The robot state's fields for the viewers: its arrays of numbers that hold a NaN or
    ±inf are arrays of number texts."""
    first = session.first
    if _NON_FINITE in first.robot_state.fields:
        raise ExportError(
            f"{session.log}: robot-state field {_NON_FINITE!r} has the name of the field "
            "that lists NaN and infinite values; export as a table instead"
        )
    return _numbers_as_text(first.robot_state, first.non_finite_arrays)


def _write_mcap(part: Path, session: _Session, replayed: ReplayResult | None) -> None:
    log, header, first = session.log, session.header, session.first
    robot_state_field = _robot_state_field(session)
    outputs_field = _typed_object(first.output_types)
    with part.open("wb") as file:
        writer = Writer(file)
        writer.start(profile="", library=f"beatlog {__version__}")
        writer.add_metadata("beatlog", {**_log_metadata(session), "log_time": _LOG_TIME})
        channels = _McapChannels(writer, log, header.start_time_ns)
        robot_state_name = header.robot_state_type or "beatlog.RobotState"
        robot_state = channels.add(
            "/robot_state",
            robot_state_name,
            _robot_state_schema(robot_state_name, robot_state_field),
        )
        behaviors = {
            name: channels.add(f"/behaviors/{name}", "beatlog.BehaviorState", _BEHAVIOR_SCHEMA)
            for name in header.behaviors
        }
        state_changes = channels.add("/state_changes", "foxglove.Log", foxglove.LOG_SCHEMA)
        outputs = channels.add("/outputs", "beatlog.Outputs", _outputs_schema(outputs_field))
        random_numbers = channels.add("/random_numbers", "beatlog.RandomNumbers", _RANDOM_SCHEMA)
        heartbeat = channels.add("/heartbeat", "beatlog.Heartbeat", _HEARTBEAT_SCHEMA)
        samples = _SampleChannels(channels, first.samples, log)
        poses = _PoseChannel(channels, _pose_of(first.robot_state))
        divergence = None if replayed is None else replayed.divergence
        found = (
            None
            if divergence is None
            else channels.add("/divergence", "beatlog.Divergence", _DIVERGENCE_SCHEMA)
        )
        states = dict(session.first.initial)
        write = channels.write
        for cycle in session.cycles:
            number = cycle.number
            non_finite: list[str] = []
            state = _written_object(robot_state_field.fields, cycle.robot_state, "", non_finite)
            write(robot_state, cycle, _with_non_finite(state, non_finite), "robot state")
            interval_ns = cycle.heartbeat_ns
            heartbeat_message = {
                "cycle": number,
                "interval_ns": interval_ns,
                "interval_ms": interval_ns / 1e6,
            }
            write(heartbeat, cycle, heartbeat_message, "heartbeat")
            _states_after(states, cycle.changes)
            if number == 0:
                for name, channel in behaviors.items():
                    message = {"cycle": 0, "state": _state_text(states[name])}
                    write(channel, cycle, message, "behavior state")
            for change in cycle.changes:
                lane = behaviors.get(change.behavior)
                if number > 0 and lane is not None:
                    message = {"cycle": number, "state": _state_text(change.after)}
                    write(lane, cycle, message, "behavior state")
                message = _log_message(channels.stamp(cycle), change)
                write(state_changes, cycle, message, "state change")
            non_finite = []
            written = _written_object(outputs_field.fields, cycle.outputs, "outputs.", non_finite)
            message = _with_non_finite({"cycle": number, "outputs": written}, non_finite)
            write(outputs, cycle, message, "outputs")
            if cycle.draws:
                write(random_numbers, cycle, _draws_message(cycle, log), "random numbers")
            samples.write(cycle)
            poses.write(cycle)
            if found is not None and divergence is not None and divergence.cycle == number:
                message = _divergence_message(divergence, replayed.reproduce if replayed else "")
                write(found, cycle, message, "divergence")
        writer.finish()  # type: ignore[no-untyped-call]


class _SampleChannels:
    """A channel per sensor whose samples the log holds, each sample a message."""

    def __init__(
        self, channels: _McapChannels, samples: Mapping[str, _Field | None], log: Path
    ) -> None:
        self._channels = channels
        self._log = log
        self._sensors = {}
        for sensor, field in samples.items():
            value = field or _BY_TYPE["json"]
            topic = _sample_topic(sensor)
            name = f"beatlog.Sample{topic.removeprefix('/samples')}"
            self._sensors[sensor] = (
                channels.add(topic, name, _sample_schema(sensor, value)),
                value,
            )

    def write(self, cycle: _Cycle) -> None:
        for sample in cycle.samples:
            channel, field = self._sensors[sample.sensor]
            non_finite: list[str] = []
            try:
                value = _written(field, sample.value, "value", non_finite)
            except RecursionError:
                raise _too_deep(self._log, cycle.number) from None
            message = {"cycle": cycle.number, "stamp_ns": sample.stamp_ns}
            if value is not _GAP:
                message["value"] = value
            self._channels.write(channel, cycle, _with_non_finite(message, non_finite), "samples")


class _PoseChannel:
    """The robot's pose each cycle, as a ``foxglove.FrameTransform`` for the 3D panel; no
    channel when the robot state holds no pose."""

    def __init__(self, channels: _McapChannels, pose: _Pose | None) -> None:
        self._channels = channels
        self._pose = (
            None
            if pose is None
            else (
                pose,
                channels.add(
                    _POSE_TOPIC, "foxglove.FrameTransform", foxglove.FRAME_TRANSFORM_SCHEMA
                ),
            )
        )

    def write(self, cycle: _Cycle) -> None:
        """The cycle's pose; none when the robot state holds a NaN or ±inf in it."""
        if self._pose is None:
            return
        pose, channel = self._pose
        placed = pose.of(cycle.robot_state)
        if placed is not None:
            position, yaw = placed
            time_ns = self._channels.stamp(cycle)
            message = foxglove.frame_transform(time_ns, *_POSE_FRAMES, position, yaw)
            self._channels.write(channel, cycle, message, "pose")


def _with_non_finite(message: dict[str, Any], non_finite: list[str]) -> dict[str, Any]:
    if non_finite:
        message[_NON_FINITE] = non_finite
    return message


def _log_message(time_ns: int, change: StateChange) -> dict[str, Any]:
    """A behavior state change as a ``foxglove.Log`` message."""
    message = f"{change.behavior}: {change.before} -> {change.after}"
    return foxglove.log_message(time_ns, foxglove.LOG_INFO, message, change.behavior)


def _draws_message(cycle: _Cycle, log: Path) -> dict[str, Any]:
    where = f"a random number of cycle {cycle.number}"
    return {
        "cycle": cycle.number,
        "draws": [
            {
                "actor": actor,
                "kind": draw.kind,
                "value": _json_text(draw.value, log, where).decode(),
                "params": _json_text(draw.params, log, where).decode(),
            }
            for actor, draw in cycle.draws
        ],
    }


def _divergence_message(divergence: Divergence, reproduce: str) -> dict[str, Any]:
    def changes(which: Sequence[StateChange]) -> list[dict[str, str]]:
        return [
            {
                "behavior": change.behavior,
                "before": _state_text(change.before),
                "after": _state_text(change.after),
            }
            for change in which
        ]

    return {
        "cycle": divergence.cycle,
        "kind": divergence.kind.value,
        "message": divergence.message,
        "behavior": divergence.behavior or "",
        "expected": changes(divergence.expected),
        "actual": changes(divergence.actual),
        "reproduce": reproduce,
    }


# Tables

_FIRST_COLUMNS = ("cycle", "time_ns", "heartbeat_ns")
_DRAWS_COLUMN = "draws"


def _write_table(part: Path, session: _Session, chosen: ExportFormat) -> None:
    """One row per cycle, the columns typed by the robot-state schema, the catalogue and
    the outputs' types, so every log of a system has the same columns of the same types."""
    log, first = session.log, session.first
    states = dict(first.initial)
    state_columns = _state_columns(first.robot_state.fields)
    behavior_columns = {name: f"behavior.{name}" for name in session.header.behaviors}
    output_columns = {name: f"out.{name}" for name in first.output_types}
    others = [*_FIRST_COLUMNS, *behavior_columns.values(), *output_columns.values(), _DRAWS_COLUMN]
    clash = next((name for name in state_columns if name in others), None)
    if clash is not None:
        raise ExportError(
            f"{log}: robot-state field {clash!r} has the name of another column; "
            "export as MCAP instead"
        )
    columns: dict[str, _Field] = {
        **dict.fromkeys(_FIRST_COLUMNS, _BY_TYPE["integer"]),
        **{column: field for column, (_, field) in state_columns.items()},
        **dict.fromkeys(behavior_columns.values(), _BY_TYPE["string"]),
        **{
            column: _BY_TYPE["number" if kind == "integer" else kind or "json"]
            for column, kind in zip(
                output_columns.values(), first.output_types.values(), strict=True
            )
        },
        _DRAWS_COLUMN: _BY_TYPE["integer"],
    }
    values: dict[str, list[Any]] = {column: [] for column in columns}
    for cycle in session.cycles:
        _states_after(states, cycle.changes)
        values["cycle"].append(cycle.number)
        values["time_ns"].append(cycle.time_ns)
        values["heartbeat_ns"].append(cycle.heartbeat_ns)
        for column, (keys, _) in state_columns.items():
            values[column].append(_at(cycle.robot_state, keys))
        for name, column in behavior_columns.items():
            state = states[name]
            values[column].append(None if state is None else _state_text(state))
        for name, column in output_columns.items():
            values[column].append(cycle.outputs.get(name))
        values[_DRAWS_COLUMN].append(len(cycle.draws))
    if chosen is ExportFormat.CSV:
        with part.open("w", encoding="utf-8", newline="") as file:
            table = csv.writer(file)
            table.writerow(columns)
            for number, row in enumerate(zip(*values.values(), strict=True)):
                table.writerow([_cell(value, log, f"cycle {number}") for value in row])
        return
    _write_parquet(part, session, columns, values)


def _state_columns(
    fields: Mapping[str, _Field], keys: tuple[str, ...] = ()
) -> dict[str, tuple[tuple[str, ...], _Field]]:
    """The robot state's columns, a nested struct's fields as ``a.b``: the keys that reach
    each one's value, and its field."""
    columns = {}
    for name, field in fields.items():
        path = (*keys, name)
        if field.kind is _Kind.OBJECT:
            columns.update(_state_columns(field.fields, path))
        else:
            columns[".".join(path)] = (path, field)
    return columns


def _at(value: Any, keys: Sequence[str]) -> Any:
    """The value ``keys`` reach in nested maps; None where one is missing."""
    for key in keys:
        if not isinstance(value, dict):
            return None
        value = value.get(key)
    return value


def _write_parquet(
    part: Path, session: _Session, columns: Mapping[str, _Field], values: Mapping[str, list[Any]]
) -> None:
    """Parquet with an Arrow schema from ``columns`` and the log described in its metadata."""
    pa, parquet = _pyarrow()
    log = session.log
    arrays = []
    for column, field in columns.items():
        arrow_type, as_json = _arrow_type(pa, field)
        cells = values[column]
        if as_json or field == _BASE64:
            where = f"column {column!r}"
            cells = [
                cell if cell is None else _cell(cell, log, where, json=as_json) for cell in cells
            ]
        try:
            arrays.append(pa.array(cells, type=arrow_type))
        except (pa.ArrowException, OverflowError) as exc:
            raise CorruptLogError(
                log, f"column {column!r} does not hold the {arrow_type} it is declared as: {exc}"
            ) from None
    metadata = {f"beatlog.{key}": value for key, value in _log_metadata(session).items()}
    schema = pa.schema(
        [pa.field(column, array.type) for column, array in zip(columns, arrays, strict=True)],
        metadata=metadata,
    )
    parquet.write_table(pa.Table.from_arrays(arrays, schema=schema), part)


def _arrow_type(pa: Any, field: _Field) -> tuple[Any, bool]:
    """The Arrow type of a column of ``field``, and whether its cells are JSON text: a
    number is a double, an integer an int64, an array of those a list; what has no
    Arrow type here (a map, a union, an array of structs) is JSON text."""
    if field.kind is _Kind.NUMBER:
        return pa.float64(), False
    if field.kind is _Kind.PLAIN:
        declared = field.schema["type"]
        return {"integer": pa.int64(), "boolean": pa.bool_()}.get(declared, pa.string()), False
    items = field.items
    if field.kind is _Kind.ARRAY and items is not None and items.kind is not _Kind.OBJECT:
        inner, as_json = _arrow_type(pa, items)
        if not as_json:
            return pa.list_(inner), False
    return pa.string(), True


def _pyarrow() -> tuple[Any, Any]:
    """pyarrow and its Parquet module, from the optional ``export`` extra."""
    try:
        import pyarrow  # noqa: PLC0415 - optional
        import pyarrow.parquet  # noqa: PLC0415
    except ModuleNotFoundError:
        raise ExportError('Parquet export needs pyarrow (pip install "beatlog[export]")') from None
    return pyarrow, pyarrow.parquet


def _cell(value: Any, log: Path, where: str, *, json: bool = False) -> Any:
    """A table cell: bytes as base64; a list or map (with ``json``, any value) as its JSON
    text; a number, string, bool or None as it is."""
    if isinstance(value, bytes):
        return base64.b64encode(value).decode()
    if json or isinstance(value, list | dict):
        return _json_text(value, log, where).decode()
    return value
