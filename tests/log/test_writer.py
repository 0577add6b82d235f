"""Writing session logs: readable while recording, and a full disk never stops the robot."""

from __future__ import annotations

import errno
import io
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgspec
import numpy as np
import pytest

from beatlog.errors import LogError, LogExistsError
from beatlog.log.format import CycleRecord, SessionEnd
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.log.writer import SessionLogWriter
from tests.conftest import PERIOD_NS, Probe
from tests.crafting import read_all, session_header
from tests.factories import fill_the_disk

if TYPE_CHECKING:
    from _typeshed import ReadableBuffer


class DiskFull(io.BytesIO):
    """A stream that takes ``capacity`` bytes, then fails like a full disk (ENOSPC)."""

    def __init__(self, capacity: int = 1 << 30) -> None:
        super().__init__()
        self.capacity = capacity

    def write(self, data: ReadableBuffer, /) -> int:
        chunk = bytes(memoryview(data))
        room = max(self.capacity - self.tell(), 0)
        if len(chunk) > room:
            super().write(chunk[:room])
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return super().write(chunk)


def append_probe(writer: SessionLogWriter, t: int) -> None:
    """Append cycle t, whose robot state reads t."""
    writer.append(PERIOD_NS, Probe(reading=float(t)), [], [], {"t": t})


def readings(cycles: list[CycleRecord]) -> list[float]:
    return [msgspec.msgpack.decode(cycle.robot_state, type=Probe).reading for cycle in cycles]


def wait_for(condition: Callable[[], bool], timeout_s: float = 5.0) -> bool:
    """Poll until ``condition`` holds; False if it still does not after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def test_cycles_become_readable_while_the_writer_is_still_open(tmp_path: Path) -> None:
    log = tmp_path / "live.beatlog"
    seen: list[CycleRecord] = []
    statuses: list[LogStatus] = []

    def all_25_cycles_on_disk() -> bool:
        cycles, status = read_all(log)
        seen[:], statuses[:] = cycles, [status]
        return len(cycles) == 25

    with SessionLogWriter(log, session_header(), flush_interval_s=0.05) as writer:
        for t in range(25):
            append_probe(writer, t)

        assert wait_for(all_25_cycles_on_disk), f"only {len(seen)} cycles readable"
        assert readings(seen) == [float(t) for t in range(25)]
        [status] = statuses
        assert status == LogStatus(
            complete=False, cycles=25, problem="the recording stopped before the log was closed"
        )
        assert status.describe() == (
            "truncated at cycle 25: the recording stopped before the log was closed"
        )


def test_close_writes_the_end_record_and_the_log_reads_complete(tmp_path: Path) -> None:
    log = tmp_path / "closed.beatlog"
    writer = SessionLogWriter(log, session_header())
    for t in range(40):
        append_probe(writer, t)
    end = SessionEnd(cycles=40, robot_time_ns=40 * PERIOD_NS, overruns=2)

    writer.close(end)
    writer.close(SessionEnd(cycles=0, robot_time_ns=0))

    with SessionLogReader(log) as reader:
        assert readings(list(reader.cycles())) == [float(t) for t in range(40)]
        assert reader.status == LogStatus(complete=True, cycles=40)
        assert reader.end == end
    assert writer.cycles_written == 40
    assert writer.error is None


def test_a_log_closed_without_an_end_record_reads_as_cut_off(tmp_path: Path) -> None:
    log = tmp_path / "no-end.beatlog"
    with SessionLogWriter(log, session_header()) as writer:
        append_probe(writer, 0)

    cycles, status = read_all(log)

    assert len(cycles) == 1
    assert status.describe() == "truncated at cycle 1: the log has no end record"


def test_a_cycle_is_encoded_when_appended_so_later_changes_do_not_leak_in(
    tmp_path: Path,
) -> None:
    log = tmp_path / "snapshot.beatlog"
    state = Probe(distance=0.7)
    outputs: dict[str, Any] = {"speed": 0.5}
    with SessionLogWriter(log, session_header()) as writer:
        writer.append(PERIOD_NS, state, [], [], outputs)
        state.distance = 0.1
        outputs["speed"] = 0.0

    [cycle], _ = read_all(log)

    assert msgspec.msgpack.decode(cycle.robot_state, type=Probe).distance == 0.7
    assert msgspec.msgpack.decode(cycle.outputs) == {"speed": 0.5}


def test_numpy_values_in_outputs_are_recorded_as_plain_values(tmp_path: Path) -> None:
    log = tmp_path / "numpy.beatlog"
    outputs = {"gain": np.float32(0.5), "count": np.int64(3), "wheels": np.array([1.5, -2.0])}
    with SessionLogWriter(log, session_header()) as writer:
        writer.append(PERIOD_NS, Probe(), [], [], outputs)

    [cycle], _ = read_all(log)

    assert msgspec.msgpack.decode(cycle.outputs) == {"gain": 0.5, "count": 3, "wheels": [1.5, -2.0]}


def test_a_value_that_cannot_be_recorded_is_refused_at_once(tmp_path: Path) -> None:
    with SessionLogWriter(tmp_path / "odd.beatlog", session_header()) as writer:
        with pytest.raises(TypeError, match="cannot record a value of type object"):
            writer.append(PERIOD_NS, Probe(), [], [], {"thing": object()})
        append_probe(writer, 1)

    cycles, _ = read_all(tmp_path / "odd.beatlog")
    assert readings(cycles) == [1.0]


def test_a_full_disk_stops_the_log_but_never_the_robot(tmp_path: Path) -> None:
    disk = DiskFull()
    writer = SessionLogWriter(disk, session_header(), batch_cycles=10, chunk_size=1)
    disk.capacity = disk.tell() + 1500
    try:
        for t in range(100):
            append_probe(writer, t)
        assert wait_for(lambda: writer.error is not None), "the write never failed"
        for t in range(100, 150):
            append_probe(writer, t)
    finally:
        writer.close(SessionEnd(cycles=150, robot_time_ns=150 * PERIOD_NS))

    assert isinstance(writer.error, OSError)
    assert writer.error.errno == errno.ENOSPC
    assert len(disk.getvalue()) == disk.capacity
    log = tmp_path / "full.beatlog"
    log.write_bytes(disk.getvalue())
    cycles, status = read_all(log)
    assert 10 <= len(cycles) < 100
    assert readings(cycles) == [float(t) for t in range(len(cycles))]
    assert (status.complete, status.cycles) == (False, len(cycles))
    assert status.describe().startswith(f"truncated at cycle {len(cycles)}: ")


def test_a_disk_full_before_the_header_is_a_log_error() -> None:
    with pytest.raises(LogError, match="cannot write: No space left on device"):
        SessionLogWriter(DiskFull(capacity=0), session_header())


@pytest.mark.parametrize("overwrite", [False, True])
def test_a_log_file_whose_header_does_not_fit_on_the_disk_is_removed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, overwrite: bool
) -> None:
    log = tmp_path / "session.beatlog"
    fill_the_disk(monkeypatch)

    with pytest.raises(LogError) as raised:
        SessionLogWriter(log, session_header(), overwrite=overwrite)

    assert str(raised.value) == f"{log}: cannot write: No space left on device"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_a_full_device_is_a_log_error_naming_it() -> None:
    with pytest.raises(LogError) as raised:
        SessionLogWriter(Path("/dev/full"), session_header(), overwrite=True)

    assert str(raised.value) == "/dev/full: cannot write: No space left on device"
    assert Path("/dev/full").is_char_device()  # a device written to is never removed


def test_a_path_in_a_missing_directory_is_a_log_error_naming_it(tmp_path: Path) -> None:
    path = tmp_path / "no-such-dir" / "session.beatlog"

    with pytest.raises(LogError) as raised:
        SessionLogWriter(path, session_header())

    assert raised.value.path == path
    assert str(raised.value) == f"{path}: cannot write: No such file or directory"


def test_an_existing_log_is_never_overwritten_unless_asked(tmp_path: Path) -> None:
    log = tmp_path / "session.beatlog"
    with SessionLogWriter(log, session_header()) as writer:
        append_probe(writer, 0)
    recorded = log.read_bytes()

    with pytest.raises(LogExistsError) as raised:
        SessionLogWriter(log, session_header())

    assert str(raised.value) == (
        f"{log}: already exists; recordings are immutable (overwrite=True replaces it)"
    )
    assert log.read_bytes() == recorded
    with SessionLogWriter(log, session_header(), overwrite=True) as writer:
        append_probe(writer, 0)
        append_probe(writer, 1)
    assert readings(read_all(log)[0]) == [0.0, 1.0]


@pytest.mark.parametrize("interval", [0.0, -1.0])
def test_the_flush_interval_must_be_positive(tmp_path: Path, interval: float) -> None:
    with pytest.raises(ValueError, match="flush interval must be positive"):
        SessionLogWriter(tmp_path / "x.beatlog", session_header(), flush_interval_s=interval)
    assert not (tmp_path / "x.beatlog").exists()


def test_a_name_that_would_drive_a_terminal_is_refused_before_recording(tmp_path: Path) -> None:
    path = tmp_path / "escape.beatlog"

    with pytest.raises(LogError) as raised:
        SessionLogWriter(path, session_header(robot_id="dog\x1b[31m"))

    assert str(raised.value) == (
        f"{path}: cannot record: robot_id 'dog\\x1b[31m' holds control characters"
    )
    assert not path.exists()
