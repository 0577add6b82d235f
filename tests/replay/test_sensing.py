"""Sensor-level replay: RS_t rebuilt from the logged samples by the perception step."""

from __future__ import annotations

import inspect
import math
from collections.abc import Sequence
from pathlib import Path

import msgspec
import pytest

from beatlog.baseline.policy import SpecOptions, UpdateMode
from beatlog.cli.main import main
from beatlog.errors import FieldError
from beatlog.log.columns import StateColumns
from beatlog.log.reader import SessionLogReader
from beatlog.model.inbox import Sample
from beatlog.model.perception import Perception
from beatlog.replay.compare import Comparison
from beatlog.replay.core import CycleOutcome
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.judge import NO_SAMPLES, replay
from beatlog.replay.verdict import Divergence, DivergenceKind, FieldDifference
from beatlog.suite.runner import Verdict, run_spec
from beatlog.suite.spec import load_spec
from tests.conftest import PERIOD_NS, Probe, distances, probe_system
from tests.factories import logged_counts
from tests.perceptions import (
    CHANGED,
    broken_perception,
    changed_perception,
    dict_perception,
    nudged_perception,
    numpy_perception,
    one_ulp_perception,
    perceive,
    perception,
    ranged_perception,
    record_with_samples,
    shifted_perception,
)
from tests.specs import write_spec
from tests.systems import probe_system_ranged
from tests.text import frames, table_row, whole_lines


def divergence_from_samples(
    folder: Path, perception: Perception, comparison: Comparison | None = None
) -> Divergence:
    """The first divergence of the probe replayed from samples through ``perception``
    (judged by ``comparison``); there must be one."""
    log = record_with_samples(folder / "samples.beatlog")
    divergence = replay(
        log, probe_system(), perception=perception, comparison=comparison
    ).divergence
    assert divergence is not None
    return divergence


@pytest.mark.parametrize("by_field", [False, True], ids=["in-records", "by-field"])
def test_the_recorded_perception_rebuilds_every_robot_state(tmp_path: Path, by_field: bool) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog", by_field=by_field)
    result = replay(log, probe_system(), perception=perception())
    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 300, "state_changes": 41, "outputs": 453, "draws": 60, "samples": 300},
    )
    assert result.cycles == 300


def test_a_state_rebuilt_under_fields_renamed_since_is_the_one_recorded(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")
    differs: list[bool] = []

    def observe(outcome: CycleOutcome) -> None:
        differs.append(outcome.perception_differs)

    result = replay(
        log,
        probe_system_ranged(),
        perception=ranged_perception(),
        migration=StateMigration({"distance": "range"}),
        observe=observe,
    )

    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 300, "state_changes": 41, "outputs": 453, "draws": 60, "samples": 300},
    )
    assert differs == [False] * 300


def test_a_pass_from_samples_counts_the_samples_perception_rebuilt_states_from(
    tmp_path: Path,
) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")

    result = replay(log, probe_system(), perception=perception())

    assert result.checked == logged_counts(log)
    assert result.checked.samples == 300  # one range sample a cycle


def test_the_samples_of_cycles_rebuilt_otherwise_are_not_counted_as_checked(
    tmp_path: Path,
) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")

    result = replay(log, probe_system(), perception=changed_perception(), keep_going=True)

    assert 0 < result.divergent_cycles < 300
    assert result.checked.samples == 300 - result.divergent_cycles


@pytest.mark.parametrize("by_field", [False, True], ids=["in-records", "by-field"])
def test_a_changed_perception_is_a_perception_divergence_naming_fields_and_samples(
    tmp_path: Path, by_field: bool
) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog", by_field=by_field)
    result = replay(log, probe_system(), perception=changed_perception())
    divergence = result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.PERCEPTION
    assert divergence.cycle == 0
    assert divergence.message == "the robot state rebuilt from the samples differs in distance"
    assert divergence.perception == (FieldDifference("distance", 1.0, pytest.approx(1.1)),)
    assert divergence.samples == (("range", [1.0, 1]),)


def test_a_perception_that_raises_is_a_perception_divergence(tmp_path: Path) -> None:
    divergence = divergence_from_samples(tmp_path, broken_perception())
    assert divergence.kind is DivergenceKind.PERCEPTION
    assert divergence.message == "perception raised ValueError: no range sensor"
    assert divergence.traceback is not None
    assert (inspect.getsourcefile(broken_perception), "broken") in frames(divergence.traceback)


def test_a_perception_that_builds_no_robot_state_is_a_perception_divergence(
    tmp_path: Path,
) -> None:
    # A dict of the probe's fields encodes to the recorded bytes; the behaviors would
    # then fail on it, and the report blame them.
    divergence = divergence_from_samples(tmp_path, dict_perception())
    assert divergence.kind is DivergenceKind.PERCEPTION
    assert divergence.message == "perception returned a dict, not a Probe"
    assert divergence.traceback is None


def test_a_rebuilt_state_holding_numpy_values_is_reported_as_plain_numbers(
    tmp_path: Path,
) -> None:
    divergence = divergence_from_samples(tmp_path, numpy_perception())
    assert divergence.kind is DivergenceKind.PERCEPTION
    assert divergence.robot_state == {"distance": 2.0, "reading": 0.0}


def test_a_log_without_samples_replays_its_recorded_states_and_says_so(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "plain.beatlog", log_samples=False)
    result = replay(log, probe_system(), perception=changed_perception())
    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 300, "state_changes": 41, "outputs": 453, "draws": 60, "samples": 0},
    )
    assert result.notes == (NO_SAMPLES,)
    assert replay(log, probe_system()).notes == ()


def test_a_spec_whose_perception_cannot_run_passes_with_a_note(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "400")
    log = record_with_samples(tmp_path / "plain.beatlog", 40, log_samples=False)
    spec = write_spec(tmp_path, "plain", log, perception=CHANGED)
    assert main(["test", "--jobs", "1", str(spec)]) == 0
    notes = [line for line in capsys.readouterr().out.splitlines() if line.startswith("note: ")]
    assert notes == [f"note: plain: {NO_SAMPLES}"]


def test_a_note_many_dtcs_share_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "400")
    log = record_with_samples(tmp_path / "plain.beatlog", 20, log_samples=False)
    for name in "abcdefg":
        write_spec(tmp_path / "suite", name, log, perception=CHANGED)
    assert main(["test", "--jobs", "1", str(tmp_path / "suite")]) == 0
    notes = [line for line in capsys.readouterr().out.splitlines() if line.startswith("note:")]
    assert notes == [f"note: 7 DTCs (a, b, c, d, e and 2 more): {NO_SAMPLES}"]


def test_a_perception_named_by_reference_is_in_the_reproduce_command(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")
    reference = CHANGED
    result = replay(log, "tests.conftest:probe_system", perception=reference)
    assert (result.ok, result.divergent_cycles) == (False, 1)
    assert result.reproduce == (
        f"beatlog replay {log} --system tests.conftest:probe_system --perception {reference}"
    )


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
    reference = CHANGED
    code = main(
        ["replay", str(log), "--system", "tests.conftest:probe_system", "--perception", reference]
    )
    out = capsys.readouterr().out
    assert code == 1
    assert "first divergence: cycle 0, t = 0.030 s, perception" in whole_lines(out)
    assert "robot state from the samples" in whole_lines(out)
    assert table_row(out, "distance = 1.0") == ["distance = 1.0", "distance = 1.1"]
    assert "samples: range [1.0, 1]" in whole_lines(out)
    reproduce = f"reproduce: beatlog replay {log} --system tests.conftest:probe_system"
    assert f"{reproduce} --perception {reference}" in whole_lines(out)


def test_a_spec_names_its_perception_and_the_suite_replays_from_samples(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")
    spec = tmp_path / "sensors.dtc.toml"
    spec.write_text(
        'name = "sensors"\npurpose = "perception"\nprocedure = []\n'
        f'log = "{log.name}"\nsystem = "tests.conftest:probe_system"\n'
        f'perception = "{CHANGED}"\n'
    )
    outcome = run_spec(load_spec(spec))
    assert outcome.result is not None
    assert outcome.result.divergence is not None
    assert outcome.result.divergence.kind is DivergenceKind.PERCEPTION


def test_a_pinned_robot_state_one_ulp_off_diverges_in_its_cycle_alone(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")
    spec = write_spec(tmp_path, "sensors", log, perception=CHANGED)
    baseline = run_spec(load_spec(spec), SpecOptions(update=UpdateMode.NEW)).update
    assert baseline is not None
    assert replay(log, probe_system(), perception=changed_perception(), baseline=baseline).ok

    result = replay(
        log, probe_system(), perception=one_ulp_perception(), baseline=baseline, keep_going=True
    )

    assert result.divergent_cycles == 1
    assert result.divergence is not None
    assert (result.divergence.kind, result.divergence.cycle) == (DivergenceKind.PERCEPTION, 95)
    assert result.divergence.perception == (
        FieldDifference("distance", 0.9, math.nextafter(0.9 * 1.1, math.inf)),
    )


def test_show_says_how_many_samples_each_sensor_logged(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "200")
    with_samples = record_with_samples(tmp_path / "samples.beatlog", 40)
    without = record_with_samples(tmp_path / "plain.beatlog", 40, log_samples=False)
    assert main(["show", str(with_samples)]) == 0
    assert "samples         40 (range 40)" in whole_lines(capsys.readouterr().out)
    assert main(["show", str(without)]) == 0
    assert "samples         not logged" in whole_lines(capsys.readouterr().out)


# robot-state tolerances


def test_a_difference_within_the_robot_state_tolerance_passes(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")
    exact = replay(log, probe_system(), perception=nudged_perception())
    lenient = Comparison(state_tolerance={"distance": 1e-6})
    tolerated = replay(log, probe_system(), perception=nudged_perception(), comparison=lenient)
    assert exact.divergence is not None
    assert exact.divergence.kind is DivergenceKind.PERCEPTION
    assert (tolerated.ok, tolerated.divergence, tolerated.counts) == (
        True,
        None,
        {"cycles": 300, "state_changes": 41, "outputs": 453, "draws": 60, "samples": 300},
    )


def test_a_tolerance_on_another_field_excuses_nothing(tmp_path: Path) -> None:
    other = Comparison(state_tolerance={"reading": 1.0})
    divergence = divergence_from_samples(tmp_path, nudged_perception(), other)
    assert divergence.kind is DivergenceKind.PERCEPTION
    assert [difference.field for difference in divergence.perception] == ["distance"]


def test_within_the_tolerance_the_behaviors_run_on_the_rebuilt_state(tmp_path: Path) -> None:
    lenient = Comparison(state_tolerance={"distance": 0.1})
    divergence = divergence_from_samples(tmp_path, shifted_perception(), lenient)
    assert divergence.kind is DivergenceKind.STATE_CHANGES  # near saw the obstacle earlier
    assert divergence.robot_state["distance"] < 0.5 <= divergence.robot_state["distance"] + 0.05


def test_a_tolerance_for_a_field_the_recorded_state_lacks_is_an_error(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog", 20)
    unknown = Comparison(state_tolerance={"distanse": 1e-6})
    with pytest.raises(FieldError) as raised:
        replay(log, probe_system(), perception=perception(), comparison=unknown)
    message = str(raised.value)
    assert message == (
        f"{log}: robot-state tolerance for 'distanse': the recorded robot state "
        "tests.conftest.Probe has no such field (it has distance, reading)"
    )


def test_a_spec_tolerates_robot_state_fields(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog", 60)
    nudged = "tests.perceptions:nudged_perception"
    exact = write_spec(tmp_path, "exact", log, perception=nudged)
    lenient = write_spec(
        tmp_path, "lenient", log, perception=nudged, robot_state_tolerance={"distance": 1e-6}
    )
    unknown = write_spec(
        tmp_path, "unknown", log, perception=nudged, robot_state_tolerance={"speed": 1e-6}
    )
    assert run_spec(load_spec(exact)).verdict is Verdict.FAILED
    assert run_spec(load_spec(lenient)).verdict is Verdict.PASSED
    outcome = run_spec(load_spec(unknown))
    assert outcome.verdict is Verdict.ERROR
    assert outcome.error is not None
    assert outcome.error == (
        f"{log}: robot-state tolerance for 'speed': the recorded robot state "
        "tests.conftest.Probe has no such field (it has distance, reading)"
    )


def failing_every_third_and_shifting_every_fifth(
    previous: Probe | None, samples: Sequence[Sample]
) -> Probe:
    """The probe's perception, except that it raises in every third cycle and reads the
    range 0.5 long in every fifth (of the others)."""
    cycle = samples[0].stamp_ns // PERIOD_NS
    if cycle % 3 == 0:
        raise ValueError("no range sensor")
    state = perceive(previous, samples)
    if cycle % 5 == 0:
        return Probe(distance=state.distance + 0.5, reading=state.reading)
    return state


def decoded_states(log: Path) -> list[Probe]:
    """Every recorded RS_t of ``log``, each decoded by msgspec from the bytes its cycle
    holds: the plain twin of the lazy decode in sensor-level replay."""
    with SessionLogReader(log) as reader:
        return [
            msgspec.msgpack.decode(
                record.robot_state.raw_state(cycle)
                if isinstance(record.robot_state, StateColumns)
                else record.robot_state,
                type=Probe,
            )
            for cycle, record in enumerate(reader.cycles())
        ]


@pytest.mark.parametrize("by_field", [False, True], ids=["in-records", "by-field"])
def test_the_recorded_state_decoded_only_where_needed_is_the_one_every_cycle_holds(
    tmp_path: Path, by_field: bool
) -> None:
    """The core decodes a cycle's recorded RS_t in sensor-level replay only where the
    rebuilt one differs or perception fails (a measured speed trick): there it is the
    state the log holds, as decoding every cycle gives it."""
    log = record_with_samples(tmp_path / "samples.beatlog", by_field=by_field)
    seen: list[CycleOutcome] = []

    replay(
        log,
        probe_system(),
        perception=failing_every_third_and_shifting_every_fifth,
        keep_going=True,
        observe=seen.append,
    )

    recorded = decoded_states(log)
    assert len(seen) == len(recorded) == 300
    failed = [outcome for outcome in seen if outcome.perception_failure is not None]
    shifted = [outcome for outcome in seen if outcome.perception_differs]
    assert [outcome.cycle for outcome in failed] == list(range(0, 300, 3))
    assert [outcome.cycle for outcome in shifted] == [c for c in range(5, 300, 5) if c % 3]
    for outcome in failed:  # the behaviors ran on the recorded state
        assert outcome.state == outcome.recorded_state == recorded[outcome.cycle]
    for outcome in shifted:
        assert outcome.recorded_state == recorded[outcome.cycle] != outcome.state
