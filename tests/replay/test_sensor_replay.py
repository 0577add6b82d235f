"""Sensor-level replay: RS_t rebuilt from the logged samples by the perception step."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import pytest

from beatlog.cli.main import main
from beatlog.model.inbox import Sample
from beatlog.model.perception import Perception
from beatlog.record.recorder import Recorder
from beatlog.replay.judge import replay
from beatlog.replay.verdict import DivergenceKind, FieldDifference
from beatlog.suite.runner import run_spec
from beatlog.suite.spec import load_spec
from tests.conftest import PERIOD_NS, Probe, distances, probe_system


def perceive(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
    """The probe's perception: the last range reading is the distance."""
    state = Probe() if previous is None else previous
    for sample in samples:
        if sample.sensor == "range":
            state = Probe(distance=sample.value[0], reading=state.reading)
    return state


def perception() -> Perception:
    return perceive


def changed_perception() -> Perception:
    """A perception change: the range is read 10 % long from a distance of 0.8 on."""

    def long_range(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
        state = perceive(previous, samples)
        distance = state.distance
        return Probe(distance=distance * 1.1 if distance >= 0.8 else distance)

    return long_range


def broken_perception() -> Perception:
    def broken(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
        if previous is not None and previous.distance < 0.5:
            raise ValueError("no range sensor")
        return perceive(previous, samples)

    return broken


def record_with_samples(path: Path, cycles: int = 300, *, log_samples: bool = True) -> Path:
    """A probe session whose robot state is perceived from one range sample a cycle."""
    state: Probe | None = None
    with Recorder(
        path, probe_system(), seed=3, software="test", log_samples=log_samples
    ) as recorder:
        for t, distance in enumerate(distances(cycles)):
            samples = [Sample("range", t * PERIOD_NS, (distance, 1))]
            state = perceive(state, samples)
            recorder.step(PERIOD_NS, state, samples)
    return path


def test_the_recorded_perception_rebuilds_every_robot_state(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")
    result = replay(log, probe_system(), perception=perception())
    assert result.ok, result.divergence
    assert result.cycles == 300


def test_a_changed_perception_is_a_perception_divergence_naming_fields_and_samples(
    tmp_path: Path,
) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")
    result = replay(log, probe_system(), perception=changed_perception())
    divergence = result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.PERCEPTION
    assert divergence.cycle == 0
    assert divergence.message == "the robot state rebuilt from the samples differs in distance"
    assert divergence.perception == (FieldDifference("distance", 1.0, pytest.approx(1.1)),)
    assert divergence.samples == (("range", [1.0, 1]),)


def test_a_perception_that_raises_is_a_perception_divergence(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")
    divergence = replay(log, probe_system(), perception=broken_perception()).divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.PERCEPTION
    assert divergence.message == "perception raised ValueError: no range sensor"
    assert divergence.traceback is not None
    assert "test_sensor_replay.py" in divergence.traceback


def test_a_log_without_samples_replays_its_recorded_states(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "plain.beatlog", log_samples=False)
    assert replay(log, probe_system(), perception=changed_perception()).ok


def test_a_perception_named_by_reference_is_in_the_reproduce_command(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")
    reference = "tests.replay.test_sensor_replay:changed_perception"
    result = replay(log, "tests.conftest:probe_system", perception=reference)
    assert not result.ok
    assert f"--perception {reference}" in result.reproduce


def test_keep_going_counts_every_cycle_perception_rebuilds_differently(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")
    far = sum(distance >= 0.8 for distance in distances(300))
    result = replay(log, probe_system(), perception=changed_perception(), keep_going=True)
    assert result.divergent_cycles >= far


def test_the_cli_replays_from_samples_and_shows_the_fields_and_samples(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "200")
    log = record_with_samples(tmp_path / "samples.beatlog")
    reference = "tests.replay.test_sensor_replay:changed_perception"
    code = main(
        ["replay", str(log), "--system", "tests.conftest:probe_system", "--perception", reference]
    )
    out = capsys.readouterr().out
    assert code == 1
    assert "perception" in out
    assert "robot state from the samples" in out
    assert "distance = 1.0" in out
    assert "samples: range [1.0, 1]" in out
    assert f"--perception {reference}" in out


def test_a_spec_names_its_perception_and_the_suite_replays_from_samples(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")
    spec = tmp_path / "sensors.dtc.toml"
    spec.write_text(
        'name = "sensors"\npurpose = "perception"\nprocedure = []\n'
        f'log = "{log.name}"\nsystem = "tests.conftest:probe_system"\n'
        'perception = "tests.replay.test_sensor_replay:changed_perception"\n'
    )
    outcome = run_spec(load_spec(spec))
    assert outcome.result is not None
    assert outcome.result.divergence is not None
    assert outcome.result.divergence.kind is DivergenceKind.PERCEPTION


def test_show_says_how_many_samples_each_sensor_logged(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "200")
    with_samples = record_with_samples(tmp_path / "samples.beatlog", 40)
    without = record_with_samples(tmp_path / "plain.beatlog", 40, log_samples=False)
    assert main(["show", str(with_samples)]) == 0
    assert "samples         40 (range 40)" in capsys.readouterr().out
    assert main(["show", str(without)]) == 0
    assert "samples         not logged" in capsys.readouterr().out
