"""Format-3 logs whose robot states are stored by field, and damage done to their columns
with every CRC holding: shared by the log, replay and conformance tests."""

from __future__ import annotations

import struct
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import msgspec

from beatlog.log.columns import array_head, column_batches
from beatlog.log.format import (
    CYCLES_TOPIC,
    END_TOPIC,
    HEADER_TOPIC,
    ColumnBatch,
    CycleRecord,
    SessionEnd,
    payload_encoder,
)
from beatlog.log.reader import SessionLogReader
from beatlog.log.writer import SessionLogWriter
from beatlog.model.state import state_fields
from tests.conftest import PERIOD_NS
from tests.crafting import Message, craft_log, session_header

Damage = Callable[[ColumnBatch], ColumnBatch]


def rewrite_by_field(log: Path, path: Path, damage: Damage, batch: int) -> Path:
    """A copy at ``path`` of the format-3 ``log`` (robot states by field, as its header
    names them), batched as its writer batched it, with batch ``batch`` what ``damage``
    makes of it, written anew with valid CRCs, summary and end record."""
    encode = payload_encoder().encode
    with SessionLogReader(log) as reader:
        header = reader.header
        messages = [Message(HEADER_TOPIC, 0, encode(header))]
        robot_time = done = 0
        for index, cycles in enumerate(reader.batches()):
            records = [encode(_without_state(record)) for record in cycles]
            states = [bytes(record.robot_state) for record in cycles]
            ((_, made),) = column_batches(done, records, states, header.state_fields)
            stamp = robot_time + cycles[0].heartbeat_ns
            altered = damage(made) if index == batch else made
            messages.append(Message(CYCLES_TOPIC, stamp, encode(altered)))
            robot_time += sum(record.heartbeat_ns for record in cycles)
            done += len(cycles)
        end = reader.end
    assert end is not None
    messages.append(Message(END_TOPIC, end.robot_time_ns, encode(end)))
    return craft_log(path, messages)


def write_states(
    path: Path, states: Sequence[msgspec.Struct], *, by_field: bool, version: int = 3
) -> Path:
    """A log at ``path`` of ``states`` (format ``version``, batches of 8 cycles), stored
    ``by_field`` or in the records."""
    fields = state_fields(type(states[0])) if by_field else []
    header = session_header(format_version=version, state_fields=fields)
    with SessionLogWriter(path, header, batch_cycles=8) as writer:
        for t, state in enumerate(states):
            writer.append(PERIOD_NS, state, [], [], {"t": t})
        writer.close(SessionEnd(cycles=len(states), robot_time_ns=len(states) * PERIOD_NS))
    return path


def _without_state(record: CycleRecord) -> list[Any]:
    """A record as a batch by field holds it: its robot state nil."""
    return [
        record.heartbeat_ns,
        None,
        record.state_changes,
        record.random_numbers,
        record.outputs,
        record.samples,
    ]


def _sizes(batch: ColumnBatch) -> list[int]:
    return list(struct.unpack(f"<{len(batch.widths)}I", batch.sizes))


def _column_start(batch: ColumnBatch, index: int) -> int:
    return sum(_sizes(batch)[:index])


def short_column(index: int) -> Damage:
    """Column ``index`` (of values of one width) loses its last byte."""

    def damage(batch: ColumnBatch) -> ColumnBatch:
        sizes = _sizes(batch)
        end = _column_start(batch, index) + sizes[index]
        sizes[index] -= 1
        data = batch.data[: end - 1] + batch.data[end:]
        packed = struct.pack(f"<{len(sizes)}I", *sizes)
        return msgspec.structs.replace(batch, sizes=packed, data=data)

    return damage


def table_off(batch: ColumnBatch) -> ColumnBatch:
    """The column table says the last column takes a byte more than the batch holds."""
    sizes = _sizes(batch)
    sizes[-1] += 1
    return msgspec.structs.replace(batch, sizes=struct.pack(f"<{len(sizes)}I", *sizes))


def foreign_value(index: int) -> Damage:
    """Column ``index``'s first value is marked ``true`` where a 9-byte float was: its
    size holds, but it no longer holds one value a cycle."""

    def damage(batch: ColumnBatch) -> ColumnBatch:
        data = bytearray(batch.data)
        data[_column_start(batch, index)] = 0xC3
        return msgspec.structs.replace(batch, data=bytes(data))

    return damage


def retyped_value(index: int, value: Any) -> Damage:
    """Column ``index`` (of values of varied width) with its first value ``value``."""

    def damage(batch: ColumnBatch) -> ColumnBatch:
        assert batch.widths[index] == 0
        start = _column_start(batch, index)
        end = start + _sizes(batch)[index]
        values = msgspec.msgpack.decode(
            array_head(len(batch.cycles)) + batch.data[start:end], type=list[msgspec.Raw]
        )
        values[0] = msgspec.Raw(msgspec.msgpack.encode(value))
        column = b"".join(values)
        sizes = _sizes(batch)
        sizes[index] = len(column)
        data = batch.data[:start] + column + batch.data[end:]
        packed = struct.pack(f"<{len(sizes)}I", *sizes)
        return msgspec.structs.replace(batch, sizes=packed, data=data)

    return damage


def same_width_values(index: int, *values: Any) -> Damage:
    """Column ``index`` (of values of one width, byte-split) with its first values
    ``values``, which take as many bytes as that many of the column's: each of the
    width, or one short and the next spilling into its place."""

    def damage(batch: ColumnBatch) -> ColumnBatch:
        width, count = batch.widths[index], len(batch.cycles)
        encoded = b"".join(map(msgspec.msgpack.encode, values))
        assert len(encoded) == width * len(values)
        data = bytearray(batch.data)
        start = _column_start(batch, index)
        for at, byte in enumerate(encoded):
            cycle, plane = divmod(at, width)
            data[start + plane * count + cycle] = byte
        return msgspec.structs.replace(batch, data=bytes(data))

    return damage


def state_in_record(batch: ColumnBatch) -> ColumnBatch:
    """The first record holds a robot state the batch also stores by field."""
    records: list[Any] = list(batch.cycles)
    parts = msgspec.msgpack.decode(msgspec.msgpack.encode(records[0]))
    parts[1] = {"distance": 0.0}
    records[0] = msgspec.Raw(msgspec.msgpack.encode(parts))
    return msgspec.structs.replace(batch, cycles=records)
