"""Writes the conformance suite: small session logs and, beside each, the JSON a reader
must produce for it (see README.md in this folder).

    python -m tests.conformance.generate [FOLDER]    # default: tests/conformance/cases

The logs are deterministic: the writer closes chunks by robot time and the crafted
logs are built byte by byte, so running this again gives the same bytes. Each
expected document is built from what was written (the header, the cycles, the end
record), never by reading the log back with beatlog's reader.
"""

from __future__ import annotations

import json
import math
import struct
import sys
from collections.abc import Sequence
from io import BytesIO
from pathlib import Path
from tempfile import TemporaryDirectory
from typing import Any

import msgspec
from mcap.exceptions import EndOfFile
from mcap.records import Channel as McapChannel
from mcap.records import Message as McapMessage
from mcap.stream_reader import StreamReader

from beatlog.log import SessionEnd, SessionHeader, SessionLogWriter
from beatlog.log.format import CYCLES_TOPIC, SETUP_DRAWS_SINCE, Draw
from tests.conformance.format3 import DAMAGES, damaged, header, written
from tests.crafting import (
    FORMAT_1_CHANNELS,
    PERIOD_NS,
    Message,
    chunks,
    craft_log,
    cycle,
    cycle_messages,
    drop_chunk,
    end_message,
    header_message,
    session_header,
)
from tests.factories import RECORD_HEAD

CASES = Path(__file__).parent / "cases"
FLUSH_INTERVAL_NS = 250_000_000
START_TIME_NS = 1_700_000_000_000_000_000
CYCLES = 40
NEWER_VERSION = 99
CUT_CHUNK = 2
"""The chunk the damaged variants are cut, zero-filled, dropped or altered in (chunk 0
holds the session header)."""

NAN_WITH_PAYLOAD = struct.unpack("<d", bytes.fromhex("010000000000f87f"))[0]
"""A NaN with a payload (bits 0x7ff8000000000001), kept bit for bit by the format."""


class Gauge(msgspec.Struct):
    """The robot state of the suite's sessions: floats that JSON alone cannot carry."""

    distance: float
    reading: float
    label: str


HEADER = SessionHeader(
    format_version=2,
    beatlog_version="conformance",
    robot_id="gauge-1",
    software_version="v1.0",
    system="conformance:gauge",
    period_ns=PERIOD_NS,
    start_time_ns=START_TIME_NS,
    robot_state_type="conformance.Gauge",
    robot_state_schema={
        "type": "object",
        "properties": {
            "distance": {"type": "number"},
            "reading": {"type": "number"},
            "label": {"type": "string"},
        },
        "required": ["distance", "reading", "label"],
    },
    behaviors=["near", "dice"],
    random_seed=7,
    samples_logged=True,
    flush_interval_ns=FLUSH_INTERVAL_NS,
)

READINGS = (0.0, -0.0, math.inf, -math.inf, NAN_WITH_PAYLOAD, 1.5, 2.5e-300, 1e300)


def recorded_cycles() -> list[tuple[Any, ...]]:
    """The cycles of the format-2 sessions, as given to the writer: heartbeat, robot
    state, state changes, random numbers, outputs and samples."""
    cycles: list[tuple[Any, ...]] = []
    near = False
    for t in range(CYCLES):
        heartbeat = PERIOD_NS + (t % 3) * 1000 + (15_000_000 if t == 17 else 0)
        distance = abs(20 - t) / 10
        state = Gauge(distance=distance, reading=READINGS[t % len(READINGS)], label=f"t{t}")
        changes: list[Any] = []
        if (distance < 0.5) != near:
            changes.append([0, "near" if near else "far", "far" if near else "near"])
            near = not near
        draws: list[Any] = []
        if t % 5 == 0:
            draws.append([1, "randint", t % 6 + 1, [1, 6]])
            draws.append([1, "uniform", 2.0 + t / 16, [2.0, 5.0]])
        if t == 10:
            values = struct.pack("<2d", 0.25, -0.0)
            draws.append([-1, "uniform_array", ["<f8", [2], values], [0.0, 1.0, [2]]])
        outputs = {"speed": 0.0 if near else 0.5, "time": t * 0.03}
        samples = [["range", 1_000 * t, distance]]
        cycles.append((heartbeat, state, changes, draws, outputs, samples))
    return cycles


def end_of(cycles: Sequence[tuple[Any, ...]]) -> SessionEnd:
    """The end record of a session that recorded ``cycles``."""
    return SessionEnd(
        cycles=len(cycles), robot_time_ns=sum(c[0] for c in cycles), overruns=1, error=None
    )


def write_session(path: Path, *, end: bool = True, header: SessionHeader = HEADER) -> None:
    """Record the session with beatlog's own writer (format 2, unless ``header`` says)."""
    cycles = recorded_cycles()
    with SessionLogWriter(
        path, header, flush_interval_s=FLUSH_INTERVAL_NS / 1e9, batch_cycles=4, overwrite=True
    ) as writer:
        for parts in cycles:
            writer.append(*parts)
        writer.close(end_of(cycles) if end else None)


def json_value(value: Any) -> Any:
    """A decoded msgpack value as the suite's JSON holds it (README.md, "Values")."""
    if isinstance(value, float):
        if math.isnan(value):
            return f"nan:{struct.unpack('<Q', struct.pack('<d', value))[0]:#018x}"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        if value == 0 and math.copysign(1, value) < 0:
            return "-0.0"
        return value
    if isinstance(value, str):
        if value in ("inf", "-inf", "-0.0") or value.startswith(("nan:", "bytes:")):
            raise ValueError(f"the string {value!r} would read as a special value")
        return value
    if isinstance(value, bytes):
        return f"bytes:{value.hex()}"
    if isinstance(value, msgspec.Struct):
        return json_value(msgspec.structs.asdict(value))
    if isinstance(value, dict):
        if not all(isinstance(key, str) for key in value):
            raise ValueError(f"a map with keys that are not strings: {value!r}")
        return {  # a field left unset is not in the log
            key: json_value(item) for key, item in value.items() if item is not msgspec.UNSET
        }
    if isinstance(value, list | tuple):
        return [json_value(item) for item in value]
    return value


def readable(
    header: SessionHeader | dict[str, Any],
    cycles: Sequence[Sequence[Any]],
    status: tuple[bool, int, str | None],
    end: SessionEnd | dict[str, Any] | None,
) -> dict[str, Any]:
    """The document for a log that reads: everything a reader yields, in the suite's JSON."""
    fields = header if isinstance(header, dict) else msgspec.structs.asdict(header)
    complete, count, problem = status
    document: dict[str, Any] = json_value(
        {
            "format_version": fields["format_version"],
            "header": fields,
            "cycles": list(cycles),
            "status": {"complete": complete, "cycles": count, "problem": problem},
            "end": end,
        }
    )
    return document


def refused(error: str, message_contains: str) -> dict[str, Any]:
    """The document for a log a reader must refuse."""
    return {"error": error, "message_contains": message_contains}


def cycles_in(data: bytes) -> int:
    """How many cycles the complete records of a log's bytes hold, read with the mcap
    library's own stream reader rather than beatlog's."""
    count = 0
    topics: dict[int, str] = {}
    try:
        for record in StreamReader(BytesIO(data)).records:
            if isinstance(record, McapChannel):
                topics[record.id] = record.topic
            elif isinstance(record, McapMessage) and topics[record.channel_id] == CYCLES_TOPIC:
                count += len(msgspec.msgpack.decode(record.data)[1])
    except EndOfFile:
        pass
    return count


def complete_session(folder: Path) -> tuple[bytes, dict[str, Any]]:
    path = folder / "complete.beatlog"
    write_session(path)
    cycles = recorded_cycles()
    return path.read_bytes(), readable(HEADER, cycles, (True, CYCLES, None), end_of(cycles))


def damaged_variants(folder: Path) -> dict[str, tuple[bytes, dict[str, Any]]]:
    """Variants of the complete session: cut, zero-filled, a chunk dropped or altered."""
    data, _ = complete_session(folder)
    cycles = recorded_cycles()
    chunk = chunks(data)[CUT_CHUNK]
    middle = chunk.offset + (chunk.end - chunk.offset) // 2
    before = cycles_in(data[: chunk.offset])
    header_chunk = chunks(data)[0]
    crc_at = chunk.offset + RECORD_HEAD + 24  # after its start and end times and size
    bad_crc = bytes([data[crc_at] ^ 1])
    return {
        "truncated": (
            data[:middle],
            readable(
                HEADER,
                cycles[:before],
                (False, before, f"the last record is cut off at byte {chunk.offset}"),
                None,
            ),
        ),
        "zero-filled-tail": (
            data[:middle] + bytes(len(data) - middle),
            readable(
                HEADER,
                cycles[:before],
                (
                    False,
                    before,
                    f"the last record is damaged at byte {chunk.offset}, zero-filled after it "
                    "(power loss?)",
                ),
                None,
            ),
        ),
        "cut-before-header": (
            data[: header_chunk.offset + 20],
            refused("corrupt", "cut off before its session header"),
        ),
        "chunk-dropped": (
            drop_chunk(data, chunk),
            refused("corrupt", f"a batch starts at cycle {cycles_in(data[: chunk.end])}"),
        ),
        "crc-mismatch": (
            data[:crc_at] + bad_crc + data[crc_at + 1 :],
            refused("corrupt", f"damaged record at byte {chunk.offset}: chunk CRC mismatch"),
        ),
    }


def without_end(folder: Path) -> tuple[bytes, dict[str, Any]]:
    path = folder / "no-end.beatlog"
    write_session(path, end=False)
    cycles = recorded_cycles()
    status = (False, CYCLES, "the log has no end record")
    return path.read_bytes(), readable(HEADER, cycles, status, None)


def format_1(folder: Path) -> tuple[bytes, dict[str, Any]]:
    """A format-1 log: cycles messages are bare lists of cycles, draws have no params."""
    header = msgspec.structs.asdict(session_header(format_version=1, start_time_ns=START_TIME_NS))
    cycles = [cycle(PERIOD_NS + t, {"level": t / 4}, outputs={"on": t % 2 == 0}) for t in range(6)]
    cycles[3][2] = [[0, "idle", "busy"]]
    cycles[3][3] = [[0, "uniform", 0.75]]
    header["behaviors"] = ["pump"]
    messages = [header_message(**header)]
    robot_time = 0
    for first in range(0, len(cycles), 4):
        batch = cycles[first : first + 4]
        stamp = robot_time + batch[0][0]
        messages.append(Message(CYCLES_TOPIC, stamp, msgspec.msgpack.encode(batch)))
        robot_time += sum(c[0] for c in batch)
    end = {"cycles": len(cycles), "robot_time_ns": robot_time, "overruns": 0, "error": None}
    messages.append(end_message(len(cycles), robot_time))
    path = craft_log(folder / "format-1.beatlog", messages, channels=FORMAT_1_CHANNELS)
    status = (True, len(cycles), None)
    return path.read_bytes(), readable(header, cycles, status, end)


def crafted(folder: Path, name: str, messages: list[Message], **options: Any) -> bytes:
    return craft_log(folder / f"{name}.beatlog", messages, **options).read_bytes()


def refused_files(folder: Path) -> dict[str, tuple[bytes, dict[str, Any]]]:
    """Files a reader must refuse outright."""
    three = [header_message(), *cycle_messages(3), end_message(3)]
    return {
        "foreign-profile": (
            crafted(folder, "foreign-profile", three, profile="ros2"),
            refused("foreign", "an MCAP file with profile 'ros2'"),
        ),
        "empty": (b"", refused("foreign", "empty file")),
        "newer-version": (
            crafted(folder, "newer-version", [header_message(format_version=NEWER_VERSION)]),
            refused("newer_version", f"written in format version {NEWER_VERSION}"),
        ),
        "end-mismatch": (
            crafted(folder, "end-mismatch", [*three[:-1], end_message(4)]),
            refused("corrupt", "the end record counts 4 cycles"),
        ),
    }


def format_3(folder: Path) -> dict[str, tuple[bytes, dict[str, Any]]]:
    """The session in format 3, robot states by field and in the records, and by field
    with a batch's columns damaged (every CRC holding)."""
    cycles = recorded_cycles()
    status = (True, CYCLES, None)
    found: dict[str, tuple[bytes, dict[str, Any]]] = {}
    for name, by_field in (("by-field", True), ("in-records", False)):
        path = written(folder, name, HEADER, cycles, end_of(cycles), by_field=by_field)
        document = readable(header(by_field, HEADER), cycles, status, end_of(cycles))
        found[f"format-3-{name}"] = (path.read_bytes(), document)
    for name, (damage, words) in DAMAGES.items():
        data = damaged(folder / "by-field.beatlog", name, damage)
        found[name] = (data, refused("corrupt", words))
    return found


SETUP_DRAWS = [
    Draw(-1, "uniform", 2.75, (2.0, 5.0)),
    Draw(-1, "normal_array", ["<f8", [2], struct.pack("<2d", 1.5, -0.5)], (0.0, 1.0, [2])),
]
"""The set-up draws of the format-4 case: what its system drew while it was built."""


def format_4(folder: Path) -> tuple[bytes, dict[str, Any]]:
    """The session in format 4, robot states by field, with the draws its system made
    at set-up in the header."""
    path = folder / "format-4-setup-draws.beatlog"
    written_header = msgspec.structs.replace(
        header(True, HEADER), format_version=SETUP_DRAWS_SINCE, setup_draws=SETUP_DRAWS
    )
    write_session(path, header=written_header)
    cycles = recorded_cycles()
    document = readable(written_header, cycles, (True, CYCLES, None), end_of(cycles))
    return path.read_bytes(), document


def cases() -> dict[str, tuple[bytes, dict[str, Any]]]:
    """Every case by name: the log's bytes and the document a reader must produce."""
    with TemporaryDirectory() as scratch:
        folder = Path(scratch)
        return {
            "complete": complete_session(folder),
            "no-end": without_end(folder),
            "format-1": format_1(folder),
            **damaged_variants(folder),
            **refused_files(folder),
            **format_3(folder),
            "format-4-setup-draws": format_4(folder),
        }


def document_text(document: dict[str, Any]) -> str:
    """A document as committed: one cycle per line, so a change reads as a small diff."""
    lines = []
    for key, value in document.items():
        if key == "cycles" and value:
            rows = ",\n  ".join(json.dumps(c, ensure_ascii=False) for c in value)
            lines.append(f' "cycles": [\n  {rows}\n ]')
        else:
            lines.append(f" {json.dumps(key)}: {json.dumps(value, ensure_ascii=False)}")
    return "{\n" + ",\n".join(lines) + "\n}\n"


def generate(folder: Path = CASES) -> list[Path]:
    """Write every case's log and document into ``folder``; the paths written."""
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for name, (data, document) in sorted(cases().items()):
        log = folder / f"{name}.beatlog"
        log.write_bytes(data)
        expected = folder / f"{name}.json"
        expected.write_text(document_text(document), encoding="utf-8")
        written += [log, expected]
    return written


if __name__ == "__main__":
    for path in generate(Path(sys.argv[1]) if len(sys.argv) > 1 else CASES):
        print(path)
