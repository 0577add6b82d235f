"""Draws at set-up in replay: the system is built once the header is read, its factory
handed the recorded set-up draws, and drawing otherwise is a divergence at set-up."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog import replay
from beatlog.analysis.timeline import build_timeline
from beatlog.baseline.policy import refusal
from beatlog.errors import CorruptLogError, SystemLoadError
from beatlog.log.format import Draw
from beatlog.model.behavior import System
from beatlog.model.random import RecordingRandom
from beatlog.model.source import RandomSource
from beatlog.record.recorder import Recorder
from beatlog.replay.baseline import Baseline
from beatlog.replay.session import ReplaySession
from beatlog.replay.setup import SetupDrawError
from beatlog.replay.verdict import DivergenceKind
from tests.conftest import PERIOD_NS, Probe, probe_system
from tests.factories import as_format_1
from tests.systems import (
    driver_system,
    driver_system_drawing_more,
    driver_system_settled,
    record_driver,
    record_session,
)


def test_a_system_whose_factory_draws_at_set_up_replays_clean(tmp_path: Path) -> None:
    log = record_driver(tmp_path / "driver.beatlog")
    result = replay(log, driver_system)
    assert result.ok, result.divergence
    assert result.checked.draws == 2  # the driver's speed and its headways, at set-up


def test_a_reference_to_a_factory_that_draws_at_set_up_replays_clean(tmp_path: Path) -> None:
    log = record_driver(tmp_path / "driver.beatlog")
    assert replay(log, "tests.systems:driver_system").ok


def test_a_replay_session_builds_the_system_a_reference_names_handing_it_the_draws(
    tmp_path: Path,
) -> None:
    log = record_driver(tmp_path / "driver.beatlog")
    with ReplaySession(log, "tests.systems:driver_system") as session:
        assert session.replayer is not None
        assert len(session.replayer.random.drawn) == 2  # served the recorded set-up draws


def test_a_draw_too_many_at_set_up_is_a_set_up_divergence(tmp_path: Path) -> None:
    log = record_driver(tmp_path / "driver.beatlog")
    result = replay(log, "tests.systems:driver_system_drawing_more")
    divergence = result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.SETUP
    assert divergence.message == (
        "at set-up, the system's factory called randint(0, 2) (#3) but only 2 were recorded"
    )
    assert (result.cycles, result.checked.draws) == (0, 0)
    assert result.reproduce == (
        f"beatlog replay {log} --system tests.systems:driver_system_drawing_more"
    )


def test_a_draw_too_few_at_set_up_is_a_set_up_divergence(tmp_path: Path) -> None:
    log = record_driver(tmp_path / "driver.beatlog")
    divergence = replay(log, driver_system_settled).divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.SETUP
    assert divergence.message == (
        "at set-up, the system's factory drew 0 of the 2 random numbers recorded; "
        "the first not drawn: uniform(20.0, 30.0)"
    )


def test_a_draw_of_another_kind_at_set_up_is_a_set_up_divergence(tmp_path: Path) -> None:
    log = record_driver(tmp_path / "driver.beatlog")

    def swapped(random: RandomSource) -> System:
        random.gauss(20.0, 30.0)
        return driver_system_settled(random)

    divergence = replay(log, swapped).divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.SETUP
    assert "called gauss(20.0, 30.0) where uniform(20.0, 30.0) was recorded" in divergence.message


def test_a_system_built_already_cannot_replay_set_up_draws(tmp_path: Path) -> None:
    log = record_driver(tmp_path / "driver.beatlog")
    with pytest.raises(SystemLoadError, match="drew 2 random numbers at set-up: replay it against"):
        replay(log, driver_system(random=RecordingRandom(seed=3)))


def test_an_old_log_without_set_up_draws_replays_against_a_factory(tmp_path: Path) -> None:
    log = as_format_1(record_session(tmp_path / "probe.beatlog", probe_system()), tmp_path / "1")
    assert replay(log, probe_system).ok
    assert replay(log, lambda random: probe_system()).ok  # takes the source, draws nothing


def test_matching_draws_refuses_a_change_to_the_set_up_draws(tmp_path: Path) -> None:
    log = record_driver(tmp_path / "driver.beatlog")
    divergence = replay(log, driver_system_drawing_more, baseline=Baseline(())).divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.SETUP
    assert refusal(divergence) == (
        "a divergence in set-up draws cannot be re-baselined: re-record the session"
    )


def record_set_up(path: Path, draw: Draw) -> Path:
    """A log of one cycle of the probe whose header holds ``draw`` as its set-up draw."""
    random = RecordingRandom(seed=3)
    random.draws.append(draw)
    with Recorder(path, probe_system(), random=random, software="test") as recorder:
        recorder.step(PERIOD_NS, Probe())
    return path


def test_a_damaged_set_up_draw_is_refused(tmp_path: Path) -> None:
    log = record_set_up(tmp_path / "damaged.beatlog", Draw(-1, "uniform", "fast", (2.0, 3.0)))
    with pytest.raises(CorruptLogError, match="damaged set-up draw 1: uniform recorded 'fast'"):
        replay(log, lambda random: probe_system())


def test_a_timeline_builds_the_system_from_its_factory(tmp_path: Path) -> None:
    log = record_driver(tmp_path / "driver.beatlog")
    assert build_timeline(log, "tests.systems:driver_system").cycles == 20


def test_the_divergence_is_raised_where_no_verdict_is_written(tmp_path: Path) -> None:
    log = record_driver(tmp_path / "driver.beatlog")
    with pytest.raises(SetupDrawError, match="at set-up, the system's factory called randint"):
        build_timeline(log, driver_system_drawing_more)
