"""A log in many small chunks for the log tests to cut and damage, and helpers to read
logs back (the ``original`` fixture of ``tests/log/conftest.py`` reads one whole)."""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import msgspec

from beatlog.log.format import CycleRecord, SessionEnd
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.log.recording import LogSource
from beatlog.log.writer import SessionLogWriter
from tests.conftest import PERIOD_NS, Probe
from tests.crafting import Record, session_header

CYCLES = 200
CYCLES_PER_CHUNK = 10


def write_chunked_log(path: Path, cycles: int = CYCLES) -> Path:
    """A complete log in many small chunks: the header, one chunk per 10 cycles, the end."""
    writer = SessionLogWriter(
        path,
        session_header(behaviors=["near"]),
        batch_cycles=CYCLES_PER_CHUNK,
        chunk_size=1,
        flush_interval_s=60.0,
    )
    for t in range(cycles):
        changes = [(0, "far", "near")] if t % 7 == 0 else []
        draws = [(0, "random", t / cycles)] if t % 3 == 0 else []
        state = Probe(distance=1.0 - t / cycles, reading=float(t))
        writer.append(PERIOD_NS + t, state, changes, draws, {"t": t})
    writer.close(SessionEnd(cycles=cycles, robot_time_ns=cycles * PERIOD_NS + sum(range(cycles))))
    return path


class Original(NamedTuple):
    data: bytes
    cycles: list[bytes]
    """Each cycle encoded, to compare byte for byte."""
    header_end: int
    cycle_chunks: list[Record]
    footer: Record


def read_all(path: LogSource) -> tuple[list[CycleRecord], LogStatus]:
    with SessionLogReader(path) as reader:
        cycles = list(reader.cycles())
        return cycles, reader.status


def encoded(cycles: list[CycleRecord]) -> list[bytes]:
    return [msgspec.msgpack.encode(cycle) for cycle in cycles]


def write(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def cut_points(first: int, last: int, count: int = 40) -> list[int]:
    """``count`` offsets spread evenly from ``first`` to ``last``, both included."""
    return [first + (last - first) * i // (count - 1) for i in range(count)]
