"""Replayability certified at record time: the log replays against a fresh system, or
the first cycle that does not and the calls to blame are named."""

from __future__ import annotations

import inspect
import io
from pathlib import Path

import pytest

from beatlog.model.random import RecordingRandom
from beatlog.record.recorder import Recorder
from tests.conftest import PERIOD_NS, Probe, distances, probe_system
from tests.systems import Gambler, driver_system, gambler_system


def test_a_deterministic_system_is_certified(tmp_path: Path) -> None:
    with Recorder(tmp_path / "s.beatlog", probe_system(), certify=probe_system) as recorder:
        for distance in distances(60):
            recorder.step(PERIOD_NS, Probe(distance=distance))
    assert recorder.certificate is not None
    assert recorder.certificate.ok
    assert recorder.certificate.describe() == (
        "certified: the log replays against a fresh system (60 cycles)"
    )
    certificate = recorder.certificate
    recorder.close()
    assert recorder.certificate is certificate  # certified once, however often closed


def test_a_behavior_drawing_from_the_global_random_is_not_certified_and_named(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    log = tmp_path / "gamble.beatlog"
    with Recorder(log, gambler_system(), certify=gambler_system) as recorder:
        for _ in range(60):
            recorder.step(PERIOD_NS, Probe())
    certificate = recorder.certificate
    assert certificate is not None
    assert not certificate.ok
    assert certificate.result.divergence is not None
    cycle = certificate.result.divergence.cycle
    lines, first = inspect.getsourcelines(Gambler.step)
    line = first + next(i for i, text in enumerate(lines) if "random.choice" in text)
    site = f"{inspect.getsourcefile(Gambler)}:{line} in Gambler.step"
    described = certificate.describe()
    assert described.startswith(
        f"not certified: a fresh system replays the log otherwise from cycle {cycle} "
        "(state changes: "
    )
    assert f"random.choice at {site}" in described
    assert described in caplog.text


def test_certifying_needs_a_log_it_can_read_back() -> None:
    with pytest.raises(ValueError, match="certify replays the log"):
        Recorder(io.BytesIO(), probe_system(), certify=probe_system)


def test_a_session_ended_by_an_exception_is_not_certified(tmp_path: Path) -> None:
    recorder = Recorder(tmp_path / "s.beatlog", probe_system(), certify=probe_system)

    def fall_over() -> None:
        with recorder:
            recorder.step(PERIOD_NS, Probe())
            raise RuntimeError("the robot fell over")

    with pytest.raises(RuntimeError):
        fall_over()
    assert recorder.certificate is None


def test_a_system_drawing_at_set_up_is_certified_against_its_factory(tmp_path: Path) -> None:
    random = RecordingRandom(seed=5)
    system = driver_system(random=random)
    with Recorder(tmp_path / "d.beatlog", system, random=random, certify=driver_system) as recorder:
        for distance in distances(30):
            recorder.step(PERIOD_NS, Probe(distance=distance))
    assert recorder.certificate is not None
    assert recorder.certificate.describe() == (
        "certified: the log replays against a fresh system (30 cycles)"
    )
