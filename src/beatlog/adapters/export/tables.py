"""The table exports, Parquet and CSV: one row per cycle, typed from the header's
robot-state schema and the behavior catalogue (see :mod:`beatlog.adapters.export`)."""

from __future__ import annotations

import base64
import csv
import io
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import IO, Any

from beatlog.adapters.export.fields import BASE64, BY_TYPE, Field, Kind, json_text, state_text
from beatlog.adapters.export.reading import Session, log_metadata, states_after
from beatlog.errors import CorruptLogError, ExportError

__all__ = ["pyarrow_modules", "write_table"]


_FIRST_COLUMNS = ("cycle", "time_ns", "heartbeat_ns")


def write_table(file: IO[bytes], session: Session, *, as_csv: bool) -> None:
    """One row per cycle, as CSV or else Parquet, the columns typed by the robot-state
    schema, the catalogue and the outputs' types, so every log of a system has the same
    columns of the same types."""
    log, first = session.log, session.first
    states = dict(first.initial)
    state_columns = _state_columns(first.robot_state.fields)
    behavior_columns = {name: f"behavior.{name}" for name in session.header.behaviors}
    output_columns = {name: f"out.{name}" for name in first.output_types}
    others = [*_FIRST_COLUMNS, *behavior_columns.values(), *output_columns.values(), "draws"]
    clash = next((name for name in state_columns if name in others), None)
    if clash is not None:
        raise ExportError(
            f"{log}: robot-state field {clash!r} has the name of another column; "
            "export as MCAP instead"
        )
    columns: dict[str, Field] = {
        **dict.fromkeys(_FIRST_COLUMNS, BY_TYPE["integer"]),
        **{column: field for column, (_, field) in state_columns.items()},
        **dict.fromkeys(behavior_columns.values(), BY_TYPE["string"]),
        **{  # an output of integers is doubles: another log may hold floats
            f"out.{name}": BY_TYPE["number"]
            if field == BY_TYPE["integer"]
            else field or BY_TYPE["json"]
            for name, field in first.output_types.items()
        },
        "draws": BY_TYPE["integer"],
    }
    values: dict[str, list[Any]] = {column: [] for column in columns}
    for cycle in session.cycles:
        states_after(states, cycle.changes)
        values["cycle"].append(cycle.number)
        values["time_ns"].append(cycle.time_ns)
        values["heartbeat_ns"].append(cycle.heartbeat_ns)
        for column, (keys, _) in state_columns.items():
            values[column].append(_at(cycle.robot_state, keys))
        for name, column in behavior_columns.items():
            state = states[name]
            values[column].append(None if state is None else state_text(state))
        for name, column in output_columns.items():
            values[column].append(cycle.outputs.get(name))
        values["draws"].append(len(cycle.draws))
    if as_csv:
        with io.TextIOWrapper(file, encoding="utf-8", newline="") as text:
            table = csv.writer(text)
            table.writerow(columns)
            for number, row in enumerate(zip(*values.values(), strict=True)):
                table.writerow([_cell(value, log, f"cycle {number}") for value in row])
        return
    _write_parquet(file, session, columns, values)


def _state_columns(
    fields: Mapping[str, Field], keys: tuple[str, ...] = ()
) -> dict[str, tuple[tuple[str, ...], Field]]:
    """The robot state's columns, a nested struct's fields as ``a.b``: the keys that reach
    each one's value, and its field."""
    columns = {}
    for name, field in fields.items():
        path = (*keys, name)
        if field.kind is Kind.OBJECT:
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
    file: IO[bytes],
    session: Session,
    columns: Mapping[str, Field],
    values: Mapping[str, list[Any]],
) -> None:
    """Parquet with an Arrow schema from ``columns`` and the log described in its metadata."""
    pa, parquet = pyarrow_modules()
    log = session.log
    arrays = []
    for column, field in columns.items():
        arrow_type, as_json = _arrow_type(pa, field)
        cells = values[column]
        if as_json or field == BASE64:
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
    metadata = {f"beatlog.{key}": value for key, value in log_metadata(session).items()}
    schema = pa.schema(
        [pa.field(column, array.type) for column, array in zip(columns, arrays, strict=True)],
        metadata=metadata,
    )
    parquet.write_table(pa.Table.from_arrays(arrays, schema=schema), file)


def _arrow_type(pa: Any, field: Field) -> tuple[Any, bool]:
    """The Arrow type of a column of ``field``, and whether its cells are JSON text: a
    number is a double, an integer an int64, an array of those a list; what has no
    Arrow type here (a map, a union, an array of structs) is JSON text."""
    if field.kind is Kind.NUMBER:
        return pa.float64(), False
    if field.kind is Kind.PLAIN:
        declared = field.schema["type"]
        return {"integer": pa.int64(), "boolean": pa.bool_()}.get(declared, pa.string()), False
    items = field.items
    if field.kind is Kind.ARRAY and items is not None and items.kind is not Kind.OBJECT:
        inner, as_json = _arrow_type(pa, items)
        if not as_json:
            return pa.list_(inner), False
    return pa.string(), True


def pyarrow_modules() -> tuple[Any, Any]:
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
        return json_text(value, log, where).decode()
    return value
