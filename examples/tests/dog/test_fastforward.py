"""Fast-forward recording: lockstep physics, jitter drawn from live intervals, exact logs."""

from __future__ import annotations

import itertools
from pathlib import Path

import msgspec
import pytest

from beatlog import replay
from beatlog.analysis.summary import summarize
from beatlog.log.reader import SessionLogReader
from beatlog_examples.dog.behaviors import DogState
from beatlog_examples.dog.fastforward import measured_intervals, record_fast
from beatlog_examples.dog.scenarios import scenario

JITTER = [29_800_000, 30_000_000, 30_050_000, 30_200_000, 33_000_000]


def test_the_same_seed_and_intervals_give_the_same_log_byte_for_byte(tmp_path: Path) -> None:
    first, second = tmp_path / "a.beatlog", tmp_path / "b.beatlog"
    for path in (first, second):
        record_fast(path, scenario("push-over"), intervals=JITTER, seed=4, duration_s=8.0)
    assert first.read_bytes() == second.read_bytes()


@pytest.mark.slow
def test_heartbeats_are_drawn_from_the_measured_intervals_and_the_log_replays(
    tmp_path: Path,
) -> None:
    log = tmp_path / "remote.beatlog"
    summary = record_fast(log, scenario("remote-drive"), intervals=JITTER, seed=1)
    assert summary.robot_time_ns >= 35e9
    intervals = measured_intervals([log])
    assert set(intervals) <= set(JITTER)
    assert len(set(intervals)) == len(JITTER)
    assert replay(log, "beatlog_examples.dog:system").ok
    transitions = summarize(log).transitions
    assert transitions["remote"] >= 6  # three drives, each started and released
    with SessionLogReader(log) as reader:
        assert reader.header.system == "beatlog_examples.dog:system"


def test_a_short_log_s_heartbeats_are_drawn_from_the_measured_intervals_and_it_replays(
    tmp_path: Path,
) -> None:
    log = tmp_path / "short.beatlog"
    record_fast(log, scenario("remote-drive"), intervals=JITTER, seed=1, duration_s=2.0)
    intervals = measured_intervals([log])
    assert set(intervals) == set(JITTER)
    assert replay(log, "beatlog_examples.dog:system").ok


def test_fast_forward_needs_intervals(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="measured heartbeat intervals"):
        record_fast(tmp_path / "x.beatlog", scenario("push-over"), intervals=[])


def test_while_the_imu_boots_perception_keeps_the_robot_states_defaults(tmp_path: Path) -> None:
    log = tmp_path / "late.beatlog"
    record_fast(log, scenario("imu-late"), intervals=JITTER, seed=3, duration_s=1.0)
    with SessionLogReader(log) as reader:
        states = [msgspec.msgpack.decode(cycle.robot_state) for cycle in reader.cycles()]
    booting = [state for state in states[:16] if state["accel_z"] == DogState().accel_z]
    assert len(booting) == 16  # 0.5 s at 30 ms, no IMU sample yet
    assert states[-1]["accel_z"] != DogState().accel_z


@pytest.mark.slow
def test_a_remote_link_that_drops_sends_no_release_and_the_dog_times_out(tmp_path: Path) -> None:
    log = tmp_path / "dropped.beatlog"
    record_fast(log, scenario("remote-dropped"), intervals=JITTER, seed=2)
    with SessionLogReader(log) as reader:
        active = [
            msgspec.msgpack.decode(cycle.robot_state, type=DogState).remote_active
            for cycle in reader.cycles()
        ]
    releases = sum(1 for before, after in itertools.pairwise(active) if before and not after)
    assert releases == 1, "one drive released, three dropped"
    assert replay(log, "beatlog_examples.dog:system").ok
    assert summarize(log).transitions["remote"] >= 8  # four drives, each taken over and ended
