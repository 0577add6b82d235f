"""Recording (Algorithm 1): from a robot's own loop with step, or the ready loop run."""

from __future__ import annotations

import enum
import errno
import io
import os
import platform
import re
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import pytest

from beatlog import replay
from beatlog.analysis.summary import summarize
from beatlog.errors import LogExistsError, NumpyMissingError, SchemaMismatchError
from beatlog.log.format import FORMAT_VERSION, SETUP_DRAWS_SINCE
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.model.clock import LiveHeartbeat
from beatlog.model.context import Outputs
from beatlog.model.inbox import Sample, SensorInbox
from beatlog.model.invariant import Cycle
from beatlog.model.random import RecordingRandom
from beatlog.record.recorder import Recorder
from tests.conftest import PERIOD_NS, Probe, probe_system
from tests.systems import (
    Simulated,
    driver_system,
    fragile_system,
    perceive_simulated,
    record_scatter,
    typist_system,
)


def test_step_returns_outputs_and_the_header_describes_the_session(tmp_path: Path) -> None:
    log = tmp_path / "s.beatlog"
    with Recorder(
        log, probe_system(), robot_id="dog-7", seed=99, period_ns=PERIOD_NS, software="v1.2"
    ) as recorder:
        outputs = recorder.step(PERIOD_NS, Probe(distance=0.2))
        assert outputs == {"speed": 0.0}
        recorder.step(PERIOD_NS, Probe(distance=0.9))
        assert recorder.cycles == 2
    with SessionLogReader(log) as reader:
        header = reader.header
        cycles = list(reader.cycles())
        assert reader.status == LogStatus(complete=True, cycles=2)
        assert reader.end is not None
        assert reader.end.cycles == 2
    assert header.robot_id == "dog-7"
    assert header.random_seed == 99
    assert header.software_version == "v1.2"
    assert header.behaviors == ["arbiter", "near", "dice"]
    assert header.robot_state_type == "tests.conftest.Probe"
    assert set(header.robot_state_schema["$defs"]["Probe"]["properties"]) == {
        "distance",
        "reading",
    }
    assert [c.heartbeat_ns for c in cycles] == [PERIOD_NS, PERIOD_NS]


def test_the_same_session_gives_the_same_records_only_the_start_time_differs(
    tmp_path: Path,
) -> None:
    def recorded(name: str, start_time_ns: int | None) -> Path:
        log = tmp_path / name
        with Recorder(
            log, probe_system(), seed=7, software="v1", start_time_ns=start_time_ns
        ) as recorder:
            for cycle in range(40):
                recorder.step(PERIOD_NS, Probe(distance=cycle / 40))
        return log

    now, later = recorded("now", None), recorded("later", None)
    fixed, same = recorded("fixed", 1_000), recorded("same", 1_000)

    with SessionLogReader(now) as first, SessionLogReader(later) as second:
        assert first.header.start_time_ns != second.header.start_time_ns
        assert msgspec.structs.replace(first.header, start_time_ns=0) == msgspec.structs.replace(
            second.header, start_time_ns=0
        )
        assert list(first.cycles()) == list(second.cycles())
    assert fixed.read_bytes() == same.read_bytes()


def test_a_recording_never_replaces_an_existing_log_unless_asked(tmp_path: Path) -> None:
    log = tmp_path / "s.beatlog"
    with Recorder(log, probe_system(), software="first") as recorder:
        recorder.step(PERIOD_NS, Probe())
    first = log.read_bytes()

    with pytest.raises(LogExistsError, match=re.escape(f"{log}: already exists")):
        Recorder(log, probe_system(), software="second")
    assert log.read_bytes() == first

    with Recorder(log, probe_system(), overwrite=True, software="second") as recorder:
        recorder.step(PERIOD_NS, Probe())
    with SessionLogReader(log) as reader:
        assert reader.header.software_version == "second"


class PushRobot:
    """A robot whose 'driver' is the perception step itself: one sample per beat."""

    def __init__(self) -> None:
        self.system = probe_system()
        self.inbox = SensorInbox()
        self.started = self.stopped = False
        self.acted: list[Outputs] = []
        self.beats = 0

    def start(self) -> None:
        self.started = True

    def stop(self) -> None:
        self.stopped = True

    def perceive(self, previous: Any | None, samples: Sequence[Sample]) -> Probe:
        self.beats += 1
        self.inbox.push("range", 1.0 - self.beats / 20)
        distance = samples[-1].value if samples else 1.0
        return Probe(distance=distance)

    def act(self, outputs: Outputs) -> None:
        self.acted.append(dict(outputs))


def test_run_loops_on_a_live_heartbeat_and_logs_samples(tmp_path: Path) -> None:
    log = tmp_path / "live.beatlog"
    robot = PushRobot()
    with Recorder(log, robot.system, period_ns=2_000_000, log_samples=True, software="t") as rec:
        summary = rec.run(robot, duration_s=0.03, heartbeat=LiveHeartbeat(2_000_000))
    assert (robot.started, robot.stopped) == (True, True)
    assert summary.cycles == len(robot.acted) >= 1
    assert summary.robot_time_ns >= 30_000_000
    with SessionLogReader(log) as reader:
        cycles = list(reader.cycles())
    assert len(cycles) == summary.cycles
    logged = msgspec.msgpack.decode(cycles[1].samples, type=list[Sample])
    assert [s.sensor for s in logged] == ["range"]
    assert replay(log, probe_system()).ok


class FullDisk(io.BytesIO):
    """A file on a disk that fills up after ``room`` bytes: a write that does not fit fails."""

    def __init__(self, room: int) -> None:
        super().__init__()
        self.room = room

    def write(self, data: Any) -> int:
        if self.tell() + len(data) > self.room:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return super().write(data)


def test_a_full_disk_never_stops_the_control_loop_and_the_log_is_valid_up_to_it(
    tmp_path: Path,
) -> None:
    disk = FullDisk(room=6_000)
    with Recorder(disk, probe_system(), flush_interval_s=0.001, software="t", seed=7) as recorder:
        for t in range(2_000):
            recorder.step(PERIOD_NS, Probe(distance=t / 2_000))
            if t % 50 == 0:
                time.sleep(0.002)  # let the writer flush now and then, as a live loop does
    log = tmp_path / "full.beatlog"
    log.write_bytes(disk.getvalue())

    assert recorder.cycles == 2_000
    assert recorder.error == "OSError: [Errno 28] No space left on device"
    with SessionLogReader(log) as reader:
        kept = len(list(reader.cycles()))
        assert (reader.status.complete, reader.status.cycles) == (False, kept)
    assert 0 < kept < 2_000
    assert replay(log, probe_system(), allow_truncated=True).ok


def test_an_exception_in_behavior_code_while_recording_is_kept_in_the_end_record(
    tmp_path: Path,
) -> None:
    log = tmp_path / "crash.beatlog"

    def crash() -> None:
        with Recorder(log, fragile_system(), software="t") as recorder:
            recorder.step(PERIOD_NS, Probe())
            recorder.step(PERIOD_NS, Probe(distance=0.1))

    with pytest.raises(ZeroDivisionError):
        crash()
    with SessionLogReader(log) as reader:
        assert len(list(reader.cycles())) == 1
        assert reader.end is not None
        assert reader.end.error is not None
        assert reader.end.error.startswith("ZeroDivisionError")


def test_a_robot_on_its_own_loop_reports_its_overruns(tmp_path: Path) -> None:
    log = tmp_path / "own-loop.beatlog"
    with Recorder(log, probe_system(), software="test") as recorder:
        recorder.step(PERIOD_NS, Probe())
        recorder.step(2 * PERIOD_NS, Probe(), overrun=True)
        recorder.step(PERIOD_NS, Probe())
        assert recorder.overruns == 1
    summary = summarize(log)
    assert summary.end is not None
    assert summary.end.overruns == 1


def test_the_names_a_robot_package_needs_come_from_beatlog() -> None:
    import beatlog  # noqa: PLC0415 - the public names, as a user imports them

    assert beatlog.Sample("range", 0, 1.0).sensor == "range"
    assert callable(beatlog.Recorder)
    assert "Perception" in beatlog.__all__


def test_run_refuses_a_robot_whose_system_is_not_the_one_recorded(tmp_path: Path) -> None:
    robot = PushRobot()
    with (
        Recorder(tmp_path / "other.beatlog", probe_system(), software="t") as recorder,
        pytest.raises(ValueError, match=r"build the Recorder with robot\.system"),
    ):
        recorder.run(robot, duration_s=0.03)
    assert not robot.started


def test_recording_array_draws_without_numpy_names_the_log_and_the_extra(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = tmp_path / "arrays.beatlog"
    monkeypatch.setitem(sys.modules, "numpy", None)

    with pytest.raises(NumpyMissingError) as raised:
        record_scatter(log)

    assert str(raised.value) == (
        f"{log}: array draws (uniform_array, normal_array, integers_array) need numpy: "
        'pip install "beatlog[arrays]"'
    )
    assert summarize(log).cycles == 0


def test_beat_measures_each_heartbeat_on_the_clock_and_counts_the_late_ones(
    tmp_path: Path,
) -> None:
    log = tmp_path / "beats.beatlog"
    ticks = iter([5_000, 5_000 + PERIOD_NS, 5_000 + 2 * PERIOD_NS + 7, 5_000 + 4 * PERIOD_NS])
    with Recorder(log, probe_system(), software="t", clock=lambda: next(ticks)) as recorder:
        outputs = [recorder.beat(Probe(distance=d)) for d in (1.0, 0.25, 1.0, 1.0)]
        assert recorder.overruns == 1

    assert outputs == [
        {"speed": 0.5, "time": PERIOD_NS / 1e9},
        {"speed": 0.0},
        {"speed": 0.5, "time": (3 * PERIOD_NS + 7) / 1e9},
        {"speed": 0.5, "time": 5 * PERIOD_NS / 1e9},
    ]
    with SessionLogReader(log) as reader:
        intervals = [cycle.heartbeat_ns for cycle in reader.cycles()]
        assert reader.end is not None
        assert reader.end.overruns == 1
    assert intervals == [PERIOD_NS, PERIOD_NS, PERIOD_NS + 7, 2 * PERIOD_NS - 7]
    assert replay(log, probe_system()).ok


class Metres(float):
    """A float subclass, as a units library may hand one out."""


class Gear(enum.IntEnum):
    LOW = 1


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("u", np.float16(0.99)),
        ("u", np.float32(0.99)),
        ("u", np.float64(0.99)),
        ("u", Metres(0.99)),
        ("u", 1),
        *(("n", kind(3)) for kind in (np.int8, np.int16, np.int32, np.int64)),
        *(("n", kind(3)) for kind in (np.uint8, np.uint16, np.uint32, np.uint64)),
        ("n", Gear.LOW),
        ("flag", np.bool_(True)),
        ("xs", (0.5, np.float32(0.25))),
    ],
    ids=lambda value: value if isinstance(value, str) else type(value).__name__,
)
def test_behaviors_see_live_the_values_replay_hands_them(
    tmp_path: Path, field: str, value: object
) -> None:
    log = tmp_path / "sim.beatlog"
    with Recorder(log, typist_system(), software="t") as recorder:
        for _ in range(3):
            recorder.step(PERIOD_NS, Simulated(**{field: value}))  # type: ignore[arg-type]
    assert typist_system().behaviors["typist"].state == ""
    result = replay(log, typist_system())
    assert result.ok, result.divergence


def test_a_robot_state_that_cannot_be_replayed_is_refused_naming_the_field(
    tmp_path: Path,
) -> None:
    with (
        Recorder(tmp_path / "s.beatlog", typist_system(), software="t") as recorder,
        pytest.raises(SchemaMismatchError, match=re.escape("cycle 0") + ".*`float`.*`\\$.u`"),
    ):
        recorder.step(PERIOD_NS, Simulated(u="fast"))  # type: ignore[arg-type]


def test_behaviors_see_a_state_rebuilt_from_samples_as_they_saw_it_live(tmp_path: Path) -> None:
    log = tmp_path / "sensed.beatlog"
    state = None
    with Recorder(log, typist_system(), log_samples=True, software="t") as recorder:
        for t in range(5):
            samples = [Sample("range", t, 0.99 - t / 100)]
            state = perceive_simulated(state, samples)
            recorder.step(PERIOD_NS, state, samples)
    assert replay(log, typist_system(), perception=perceive_simulated).ok


def test_the_draws_a_system_made_while_it_was_built_are_its_set_up_draws(
    tmp_path: Path,
) -> None:
    random = RecordingRandom(seed=5)
    system = driver_system(random=random)
    with Recorder(tmp_path / "d.beatlog", system, random=random) as recorder:
        recorder.step(PERIOD_NS, Probe())
    with SessionLogReader(tmp_path / "d.beatlog") as reader:
        header = reader.header
        assert [(d.actor, d.call()) for d in header.drawn_at_setup()] == [
            (-1, "uniform(20.0, 30.0)"),
            (-1, "normal_array(2.0, 0.5, [2])"),
        ]
        assert header.random_seed == 5
        assert header.format_version >= SETUP_DRAWS_SINCE


def test_a_recorder_takes_a_seed_or_a_random_source_not_both(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="give the seed to the random source, not both"):
        Recorder(tmp_path / "d.beatlog", probe_system(), seed=1, random=RecordingRandom(seed=1))


def never_close(cycle: Cycle) -> None:
    if cycle.robot_state.distance <= 0.3:
        raise AssertionError(f"{cycle.robot_state.distance:.2f} m from the pole")


def broken(cycle: Cycle) -> None:
    if cycle.cycle == 3:
        raise KeyError("no such sensor")


def test_invariants_are_checked_live_and_never_stop_the_robot(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    distances = [1.0, 0.2, 0.25, 0.9, 0.1]
    with Recorder(
        tmp_path / "live.beatlog", probe_system(), software="t", invariants=[never_close, broken]
    ) as recorder:
        for distance in distances:
            recorder.step(PERIOD_NS, Probe(distance=distance))

    assert recorder.cycles == len(distances)
    assert [(v.invariant, v.cycle.cycle) for v in recorder.violations] == [
        ("never_close", 1),
        ("never_close", 2),
        ("broken", 3),
        ("never_close", 4),
    ]
    assert (
        recorder.violations[0].message
        == "invariant never_close does not hold: 0.20 m from the pole"
    )
    assert [record.getMessage() for record in caplog.records] == [
        "cycle 1, t = 0.060 s: invariant never_close does not hold: 0.20 m from the pole; "
        "the robot runs on",
        "cycle 3, t = 0.120 s: invariant broken raised KeyError: 'no such sensor'; "
        "the robot runs on",
    ]
    assert replay(tmp_path / "live.beatlog", probe_system()).ok


def test_a_recorder_checks_nothing_unless_asked(tmp_path: Path) -> None:
    with Recorder(tmp_path / "plain.beatlog", probe_system(), software="t") as recorder:
        recorder.step(PERIOD_NS, Probe(distance=0.1))

    assert recorder.violations == []


def test_the_header_names_the_python_the_session_was_recorded_under(tmp_path: Path) -> None:
    with Recorder(tmp_path / "p.beatlog", probe_system()) as recorder:
        recorder.step(PERIOD_NS, Probe())
    with SessionLogReader(tmp_path / "p.beatlog") as reader:
        assert reader.header.recorded_python() == platform.python_version()
        assert reader.format_version == FORMAT_VERSION
