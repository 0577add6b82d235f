"""Factories for tests: logs rewritten (as format 1, cut, with a damaged index), projects
that vouch for systems, counts read from a log, a disk that fills up.

Logs crafted message by message and chunk by chunk come from :mod:`tests.crafting`,
which the benchmarks use too. Everything is built in ``tmp_path``; no test commits a binary.
"""

from __future__ import annotations

import errno
import io
import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import msgspec
import pytest
from mcap.opcode import Opcode

from beatlog.log.format import (
    CYCLES_TOPIC,
    END_TOPIC,
    HEADER_TOPIC,
    CycleRecord,
    Draw,
    payload_encoder,
)
from beatlog.log.reader import SessionLogReader
from beatlog.replay.approved_state_lines import state_digest
from beatlog.replay.approved_states import RebuiltState
from beatlog.replay.verdict import Checked
from tests.crafting import FORMAT_1_CHANNELS, Message, craft_log, top_level_records

MAGIC_LENGTH = 8
RECORD_HEAD = 9


def as_format_1(log: Path, path: Path) -> Path:
    """The session of a format-2 ``log`` written again as format 1 wrote it: bare
    arrays of cycles, draws without their parameters."""
    with SessionLogReader(log) as reader:
        header = msgspec.structs.replace(
            reader.header, format_version=1, python_version=msgspec.UNSET
        )
        batches = []
        robot_time = 0
        for batch in reader.batches():
            robot_time += batch[0].heartbeat_ns
            cycles = [
                msgspec.structs.replace(
                    cycle,
                    random_numbers=msgspec.Raw(
                        msgspec.msgpack.encode(
                            [draw[:3] for draw in msgspec.msgpack.decode(cycle.random_numbers)]
                        )
                    ),
                )
                for cycle in batch
            ]
            batches.append(Message(CYCLES_TOPIC, robot_time, msgspec.msgpack.encode(cycles)))
            robot_time += sum(cycle.heartbeat_ns for cycle in batch[1:])
        end = reader.end
    assert end is not None
    messages = [
        Message(HEADER_TOPIC, 0, msgspec.msgpack.encode(header)),
        *batches,
        Message(END_TOPIC, end.robot_time_ns, msgspec.msgpack.encode(end)),
    ]
    return craft_log(path, messages, channels=FORMAT_1_CHANNELS)


def vouch(folder: Path, *systems: str) -> Path:
    """Make ``folder`` a project whose ``pyproject.toml`` vouches for ``systems``: logs
    that record one of them replay against it without naming a system."""
    listed = ", ".join(f'"{system}"' for system in systems)
    path = folder / "pyproject.toml"
    path.write_text(f"[tool.beatlog]\nsystems = [{listed}]\n", encoding="utf-8")
    return path


def logged_counts(log: Path, cycles: int | None = None) -> Checked:
    """What the first ``cycles`` cycles of ``log`` (all by default) hold to check, read
    from the log apart from replay: state changes, outputs, draws and samples."""
    with SessionLogReader(log) as reader:
        records = [record for batch in reader.batches() for record in batch][:cycles]
    decode = msgspec.msgpack.decode
    return Checked(
        state_changes=sum(len(decode(record.state_changes)) for record in records),
        outputs=sum(len(decode(record.outputs)) for record in records),
        draws=sum(len(decode(record.random_numbers)) for record in records),
        samples=sum(len(decode(record.samples)) for record in records),
    )


class FullDiskFile(io.FileIO):
    """A file on a full disk: it is created, but every write fails with ENOSPC."""

    def write(self, data: object, /) -> int:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def fill_the_disk(monkeypatch: pytest.MonkeyPatch) -> None:
    """Put every log file the session log writer opens on a full disk."""
    monkeypatch.setattr("beatlog.log.writer.open", FullDiskFile, raising=False)


def fill_the_disk_after(monkeypatch: pytest.MonkeyPatch, files: int) -> None:
    """Fill the disk once ``files`` files were opened for writing through ``Path.open``:
    every later one is created, but each write to it fails with ENOSPC."""
    opened = 0
    real_open = Path.open

    def open_on_a_filling_disk(path: Path, mode: str = "r", *args: Any, **kwargs: Any) -> Any:
        nonlocal opened
        opened += "w" in mode
        if "w" in mode and opened > files:
            return FullDiskFile(path, "w")
        return real_open(path, mode, *args, **kwargs)

    monkeypatch.setattr(Path, "open", open_on_a_filling_disk)


def cycle_parts(record: CycleRecord) -> list[Any]:
    """A cycle record's six parts, decoded: heartbeat, robot state, state changes, draws,
    outputs, samples."""
    return [
        record.heartbeat_ns,
        *(
            msgspec.msgpack.decode(part)
            for part in (
                record.robot_state,
                record.state_changes,
                record.random_numbers,
                record.outputs,
                record.samples,
            )
        ),
    ]


def rewrite_cycle(
    log: Path, path: Path, cycle: int, edit: Callable[[list[Any]], list[Any]]
) -> Path:
    """A copy at ``path`` of the format-2 ``log`` whose cycle ``cycle`` is what ``edit``
    makes of its record (:func:`cycle_parts`), written anew with valid CRCs, summary and
    end record: damage that only a check of the content finds."""
    with SessionLogReader(log) as reader:
        header = reader.header
        messages = [Message(HEADER_TOPIC, 0, msgspec.msgpack.encode(header))]
        done = robot_time = 0
        for batch in reader.batches():
            records: list[list[Any]] = []
            for record in batch:
                parts = cycle_parts(record)
                records.append(edit(parts) if done + len(records) == cycle else parts)
            stamp = robot_time + batch[0].heartbeat_ns
            messages.append(Message(CYCLES_TOPIC, stamp, msgspec.msgpack.encode([done, records])))
            done += len(batch)
            robot_time += sum(record.heartbeat_ns for record in batch)
        end = reader.end
    assert end is not None
    messages.append(Message(END_TOPIC, end.robot_time_ns, msgspec.msgpack.encode(end)))
    return craft_log(path, messages)


class CycleDamage(NamedTuple):
    """Content a recorded probe log's cycle must not hold, though every CRC is valid."""

    cycle: int
    edit: Callable[[list[Any]], list[Any]]
    """What it makes of the cycle's record (see :func:`rewrite_cycle`)."""
    problem: str
    """What the refusal says after the log's path."""


def _with_part(index: int, value: Any) -> Callable[[list[Any]], list[Any]]:
    return lambda parts: [*parts[:index], value, *parts[index + 1 :]]


PROBE_CYCLE_DAMAGE = {
    "robot-state-empty": CycleDamage(
        7,
        _with_part(1, {}),
        "robot state of cycle 7 does not fit Probe: Object missing required field `distance`",
    ),
    "robot-state-unknown-field": CycleDamage(
        7,
        _with_part(1, {"distance": 0.86, "reading": 0.0, "battery": 1.0}),
        "robot state of cycle 7 does not fit Probe: Object contains unknown field `battery`",
    ),
    "record-extra-element": CycleDamage(
        7,
        lambda parts: [*parts, 0],
        "damaged cycle 7: Expected `array` of at most length 6, got 7",
    ),
    "samples-not-an-array": CycleDamage(
        7,
        _with_part(5, 5),
        "damaged samples in cycle 7: the header declares no samples: Expected `array`, got `int`",
    ),
    "samples-undeclared": CycleDamage(
        7,
        _with_part(5, [["range", 0, 1.0]]),
        "damaged samples in cycle 7: the header declares no samples: "
        "Expected `array` of at most length 0, got 1",
    ),
    "draw-value": CycleDamage(
        5,
        _with_part(3, [[2, "randint", "six", [1, 6]]]),
        "damaged random number #1 in cycle 5: randint recorded 'six', not an int",
    ),
    "draw-actor": CycleDamage(
        5,
        _with_part(3, [[7, "randint", 4, [1, 6]]]),
        "damaged random number #1 in cycle 5: drawn by behavior #7, not in the catalogue of 3",
    ),
    "state-change-behavior": CycleDamage(
        26,
        _with_part(2, [[0, "dice", "near"], [99, "far", "near"]]),
        "damaged state changes in cycle 26: behavior #99 is not in the catalogue of 3",
    ),
}
"""Damage to a probe log (``tests.conftest``, 60 cycles or more) by name."""


def cut_in_half(log: Path) -> Path:
    """``log`` cut off halfway, in place, as a crash leaves a log written in chunks."""
    data = log.read_bytes()
    log.write_bytes(data[: len(data) // 2])
    return log


def cut_short(log: Path) -> Path:
    """A copy of ``log`` (``cut.beatlog`` beside it) that a crash cut off before its end
    record: nothing counts its cycles."""
    data = log.read_bytes()
    cut = log.with_name("cut.beatlog")
    cut.write_bytes(data[: len(data) - 200])
    return cut


def with_damaged_index(log: Path, path: Path) -> Path:
    """A copy at ``path`` of ``log`` with one bit of its first chunk index's start time
    flipped: its index is damaged, every cycle and its end record intact."""
    data = bytearray(log.read_bytes())
    first_index = next(r for r in top_level_records(bytes(data)) if r.opcode == Opcode.CHUNK_INDEX)
    data[first_index.offset + RECORD_HEAD] ^= 0x01
    path.write_bytes(bytes(data))
    return path


def speed_state(cycle: int) -> dict[str, Any]:
    """A robot state, as its fields, whose speed a retuned perception rebuilds otherwise
    in ``cycle`` (1 ms a cycle)."""
    return {"speed": cycle / 1000, "heading": math.sin(cycle), "bumped": False}


def encoded(state: dict[str, Any]) -> bytes:
    """A robot state given as its fields, as a log encodes it."""
    return payload_encoder().encode(state)


def rebuilt_states(states: dict[int, dict[str, Any]]) -> list[RebuiltState]:
    """The states as a trace collects them where perception rebuilt their speed
    otherwise, in cycle order (1 ms a cycle)."""
    return [
        RebuiltState(
            cycle,
            cycle * 1_000_000,
            {"speed": state["speed"]},
            state_digest(encoded(state)),
        )
        for cycle, state in sorted(states.items())
    ]


def through_log(draws: list[Draw]) -> list[Draw]:
    """What replay sees: the draws after msgpack encoding and decoding."""
    return msgspec.msgpack.decode(msgspec.msgpack.encode(draws), type=list[Draw])


def opened_logs(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The names of the logs opened from now on, in order, one entry an opening."""
    opened: list[str] = []
    open_log = SessionLogReader.__init__

    def counted(reader: SessionLogReader, path: str | Path, **options: Any) -> None:
        opened.append(Path(path).name)
        open_log(reader, path, **options)

    monkeypatch.setattr(SessionLogReader, "__init__", counted)
    return opened
