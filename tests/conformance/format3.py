"""The format-3 cases of the conformance suite: the session of the format-2 cases written
with robot states stored by field and stored in the records, and batches by field whose
columns are damaged while every CRC holds (see README.md in this folder)."""

from __future__ import annotations

import struct
from collections.abc import Callable
from pathlib import Path
from typing import Any

import msgspec

from beatlog.log import SessionHeader, SessionLogWriter
from beatlog.log.columns import column_batches
from beatlog.log.format import CYCLES_TOPIC, FORMAT_VERSION, ColumnBatch, CycleEntry, payload_encoder
from tests.factories import Message, craft_log, end_message, header_message

Document = dict[str, Any]
Case = tuple[bytes, Document]
FIELDS = ["distance", "reading", "label"]
DAMAGED_BATCH = 2
"""The batch the damaged cases alter (cycles 8 to 11: batches of 4)."""


def header(by_field: bool, base: SessionHeader) -> SessionHeader:
    """The format-2 cases' header in format 3, naming its robot-state fields or not."""
    fields = FIELDS if by_field else []
    return msgspec.structs.replace(base, format_version=FORMAT_VERSION, state_fields=fields)


def written(
    folder: Path,
    name: str,
    base: SessionHeader,
    cycles: list[tuple[Any, ...]],
    end: Any,
    *,
    by_field: bool,
) -> bytes:
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
    return path.read_bytes()


def batches(cycles: list[tuple[Any, ...]]) -> list[tuple[int, ColumnBatch]]:
    """The session's cycles in batches of 4 by field, with each batch's robot time stamp."""
    encode = payload_encoder().encode
    records = [encode(CycleEntry(c[0], None, *c[2:])) for c in cycles]
    states = [encode(c[1]) for c in cycles]
    stamped = []
    robot_time = 0
    for first in range(0, len(cycles), 4):
        window = slice(first, first + 4)
        ((_, batch),) = column_batches(first, records[window], states[window], FIELDS)
        stamped.append((robot_time + cycles[first][0], batch))
        robot_time += sum(c[0] for c in cycles[first : first + 4])
    return stamped


def damaged_log(
    folder: Path,
    name: str,
    base: SessionHeader,
    cycles: list[tuple[Any, ...]],
    damage: Callable[[ColumnBatch], ColumnBatch],
) -> bytes:
    """A format-3 session by field whose batch :data:`DAMAGED_BATCH` is ``damage``-d, every
    chunk's CRC computed over the damaged bytes."""
    encode = payload_encoder().encode
    messages = [header_message(**msgspec.structs.asdict(header(True, base)))]
    stamped = batches(cycles)
    for index, (stamp, batch) in enumerate(stamped):
        altered = damage(batch) if index == DAMAGED_BATCH else batch
        messages.append(Message(CYCLES_TOPIC, stamp, encode(altered)))
    robot_time = sum(c[0] for c in cycles)
    messages.append(end_message(len(cycles), robot_time))
    return craft_log(folder / f"{name}.beatlog", messages).read_bytes()


def _column_short(batch: ColumnBatch) -> ColumnBatch:
    """Field ``distance`` (9 bytes a value) loses its last byte-split value byte."""
    sizes = list(struct.unpack("<3I", batch.sizes))
    first = sizes[0]
    sizes[0] -= 1
    data = batch.data[: first - 1] + batch.data[first:]
    return msgspec.structs.replace(batch, sizes=struct.pack("<3I", *sizes), data=data)


def _table_off(batch: ColumnBatch) -> ColumnBatch:
    """The column table says the columns take a byte more than the batch holds."""
    sizes = list(struct.unpack("<3I", batch.sizes))
    sizes[2] += 1
    return msgspec.structs.replace(batch, sizes=struct.pack("<3I", *sizes))


def _foreign_value(batch: ColumnBatch) -> ColumnBatch:
    """Field ``distance``'s first value is marked ``true`` instead of a float: its size
    is right, but it no longer holds one value a cycle."""
    data = bytearray(batch.data)
    data[0] = 0xC3
    return msgspec.structs.replace(batch, data=bytes(data))


def _state_in_record(batch: ColumnBatch) -> ColumnBatch:
    """A record holds a robot state that the batch also stores by field."""
    records = list(batch.cycles)
    parts = msgspec.msgpack.decode(records[0])
    parts[1] = {"distance": 0.0}
    records[0] = msgspec.Raw(msgspec.msgpack.encode(parts))
    return msgspec.structs.replace(batch, cycles=records)


DAMAGES: dict[str, tuple[Callable[[ColumnBatch], ColumnBatch], str]] = {
    "column-short": (_column_short, "field 'distance' holds 35 bytes, not 4 values of 9 bytes"),
    "column-table-off": (_table_off, "its columns take"),
    "column-foreign-value": (_foreign_value, "damaged batch from cycle 8: field 'distance'"),
    "column-state-in-record": (_state_in_record, "damaged cycle 8: its robot state is stored"),
}
"""Each damaged case: how its batch is altered, and part of the error it must give."""
