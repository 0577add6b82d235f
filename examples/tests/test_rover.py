"""The example rover: its sessions replay, and its deliberate change is caught."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from beatlog import DivergenceKind, replay
from beatlog.analysis.summary import summarize
from beatlog.log.reader import SessionLogReader
from beatlog.record.recorder import Recorder
from beatlog_examples.rover import RoverRobot, changed_system, record_lockstep, system
from beatlog_examples.rover.behaviors import AVOID_DISTANCE
from beatlog_examples.rover.world import World


def test_the_rover_bumps_into_walls_and_sees_obstacles() -> None:
    world = World(x=1.0, y=3.05, heading=0.0)
    left, front, _right = world.ranges()
    assert front == pytest.approx(2.4 - 0.4 - 1.0 - 0.15)
    assert left > front
    world.command(1.0, 0.0)
    for _ in range(300):
        world.advance(0.01)
    assert world.bumped
    assert world.x < 2.4 - 0.4 - 0.15


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rover") / "lockstep.beatlog"
    record_lockstep(path, duration_s=120.0, seed=2)  # a seed whose session includes bumps
    return path


def test_a_lockstep_session_replays_and_passes(session: Path) -> None:
    result = replay(session, system())
    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 3999, "state_changes": 340, "outputs": 7998, "draws": 148, "samples": 0},
    )
    assert result.cycles > 3900
    assert result.robot_time_s == pytest.approx(120.0, abs=0.1)


def test_the_session_exercises_every_behavior(session: Path) -> None:
    summary = summarize(session)
    assert all(count > 0 for count in summary.transitions.values()), summary.transitions
    assert {"choice", "uniform", "gauss", "random"} <= set(summary.random_draws)


def test_the_changed_avoid_distance_fails_where_avoid_first_acts_differently(
    session: Path,
) -> None:
    result = replay(session, changed_system())
    divergence = result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.STATE_CHANGES
    front = divergence.robot_state["range_front"]
    assert AVOID_DISTANCE <= front < AVOID_DISTANCE + 0.1 or any(
        change.behavior == "avoid" for change in divergence.expected + divergence.actual
    )
    assert any(change.behavior == "avoid" for change in divergence.actual)


def test_lockstep_recording_is_deterministic(tmp_path: Path) -> None:
    first, second = tmp_path / "a.beatlog", tmp_path / "b.beatlog"
    record_lockstep(first, duration_s=20.0, seed=8)
    record_lockstep(second, duration_s=20.0, seed=8)
    assert first.read_bytes() == second.read_bytes()


@pytest.mark.slow
def test_a_live_session_records_in_real_time_and_replays(tmp_path: Path) -> None:
    log = tmp_path / "live.beatlog"
    robot = RoverRobot(seed=1)
    with Recorder(log, robot.system, software="t") as recorder:
        summary = recorder.run(robot, duration_s=1.5)
    assert summary.error is None
    assert summary.cycles >= 40
    with SessionLogReader(log) as reader:
        intervals = [c.heartbeat_ns for c in reader.cycles()]
    assert math.isclose(sum(intervals) / len(intervals), 30e6, rel_tol=0.2)
    assert replay(log, system()).ok
