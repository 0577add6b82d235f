"""The format-3 cases of the conformance suite: the session of the format-2 cases written
with robot states stored by field and stored in the records, and copies of the one by
field whose columns are damaged while every CRC holds (see README.md in this folder)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import msgspec

from beatlog.log import SessionHeader, SessionLogWriter
from beatlog.log.format import COLUMNS_SINCE
from tests.columned import (
    Damage,
    foreign_value,
    rewrite_by_field,
    short_column,
    state_in_record,
    table_off,
)

FIELDS = ["distance", "reading", "label"]
DAMAGED_BATCH = 2
"""The batch the damaged cases alter: cycles 8 and 9 (as the writer batched them)."""
DAMAGES: dict[str, tuple[Damage, str]] = {
    "column-short": (short_column(0), "field 'distance' holds 17 bytes, not 2 values of 9"),
    "column-table-off": (table_off, "damaged batch from cycle 8: its columns take"),
    "column-foreign-value": (foreign_value(0), "damaged batch from cycle 8: field 'distance'"),
    "column-state-in-record": (state_in_record, "damaged cycle 8: its robot state is stored"),
}
"""Each damaged case: how its batch is altered, and part of the error it must give."""


def header(by_field: bool, base: SessionHeader) -> SessionHeader:
    """The format-2 cases' header in format 3, naming its robot-state fields or not."""
    fields = FIELDS if by_field else []
    return msgspec.structs.replace(base, format_version=COLUMNS_SINCE, state_fields=fields)


def written(
    folder: Path,
    name: str,
    base: SessionHeader,
    cycles: list[tuple[Any, ...]],
    end: Any,
    *,
    by_field: bool,
) -> Path:
    """The session written by beatlog's writer in format 3."""
    path = folder / f"{name}.beatlog"
    with SessionLogWriter(
        path,
        header(by_field, base),
        flush_interval_s=base.flush_interval_ns / 1e9,
        batch_cycles=4,
        overwrite=True,
    ) as writer:
        for parts in cycles:
            writer.append(*parts)
        writer.close(end)
    return path


def damaged(by_field: Path, name: str, damage: Damage) -> bytes:
    """The session by field with batch :data:`DAMAGED_BATCH` damaged, CRCs valid."""
    return rewrite_by_field(
        by_field, by_field.with_name(f"{name}.beatlog"), damage, DAMAGED_BATCH
    ).read_bytes()
