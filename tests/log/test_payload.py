"""Payloads decoded: robot states with their batches, and what does not fit named by its cycle."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import msgspec
import pytest

from beatlog.errors import CorruptLogError, SchemaMismatchError
from beatlog.log.format import CYCLES_TOPIC, FORMAT_VERSION, CycleRecord
from beatlog.log.reader import LogStatus, SessionLogReader
from tests.conftest import PERIOD_NS
from tests.crafting import (
    FORMAT_1_CHANNELS,
    STANDARD_CHANNELS,
    Gauge,
    Message,
    craft_log,
    cycle,
    end_message,
    header_message,
    read_all,
    standard_messages,
)


@pytest.mark.parametrize("version", [1, FORMAT_VERSION])
def test_robot_states_decoded_with_their_batches_are_the_states_the_bytes_hold(
    tmp_path: Path, version: int
) -> None:
    messages = standard_messages(30, version=version)
    channels = FORMAT_1_CHANNELS if version == 1 else STANDARD_CHANNELS
    log = craft_log(tmp_path / "gauge.beatlog", messages, channels=channels)
    raw, _ = read_all(log)

    with SessionLogReader(log) as reader:
        reader.decode_states(Gauge)
        decoded = list(reader.cycles())
        status = reader.status

    states: list[Any] = [cycle.robot_state for cycle in decoded]
    assert status == LogStatus(complete=True, cycles=30)
    assert states == [msgspec.msgpack.decode(cycle.robot_state, type=Gauge) for cycle in raw]
    assert [cycle.heartbeat_ns for cycle in decoded] == [cycle.heartbeat_ns for cycle in raw]
    assert all(isinstance(cycle, CycleRecord) for cycle in decoded)


class _Level(msgspec.Struct):
    """Gauge's robot state read as another type with its one field."""

    level: float


def test_each_reader_decodes_into_its_own_state_type_however_many_came_before(
    tmp_path: Path,
) -> None:
    log = craft_log(tmp_path / "gauge.beatlog", standard_messages(5))

    read = []
    for state_type in (Gauge, _Level, Gauge, _Level):
        with SessionLogReader(log) as reader:
            reader.decode_states(state_type)
            read.append([type(cycle.robot_state) for cycle in reader.cycles()])

    assert read == [[Gauge] * 5, [_Level] * 5, [Gauge] * 5, [_Level] * 5]


def test_a_robot_state_that_does_not_fit_its_type_is_named_by_its_cycle(tmp_path: Path) -> None:
    cycles = [cycle() for _ in range(10)]
    cycles[7] = cycle(state={"level": "full"})
    batch = Message(CYCLES_TOPIC, PERIOD_NS, msgspec.msgpack.encode([0, cycles]))
    log = craft_log(tmp_path / "misfit.beatlog", [header_message(), batch, end_message(10)])

    with SessionLogReader(log) as reader:
        reader.decode_states(Gauge)
        with pytest.raises(SchemaMismatchError) as caught:
            list(reader.batches())

    assert str(caught.value) == (
        f"{log}: robot state of cycle 7 does not fit Gauge: "
        "Expected `float`, got `str` - at `$.level`"
    )


def test_a_damaged_batch_is_damage_when_robot_states_are_decoded_with_it(tmp_path: Path) -> None:
    payload = msgspec.msgpack.encode([0, [cycle() for _ in range(10)]])[:-3]
    batch = Message(CYCLES_TOPIC, PERIOD_NS, payload)
    log = craft_log(tmp_path / "damaged.beatlog", [header_message(), batch, end_message(10)])

    with SessionLogReader(log) as reader:
        reader.decode_states(Gauge)
        with pytest.raises(CorruptLogError, match="damaged the batch after cycle 0: "):
            list(reader.batches())
