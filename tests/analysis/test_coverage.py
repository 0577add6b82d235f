"""Transition coverage: the states and transitions a suite's recordings exercise."""

from __future__ import annotations

import enum
import json
from pathlib import Path

import pytest

from beatlog.analysis.coverage import SuiteCoverage, cover_changes, declared_states
from beatlog.analysis.recorded import read_changes
from beatlog.cli.main import main
from beatlog.model.behavior import BehaviorState, PriorityArbiter, System
from beatlog.model.context import Context, Outputs
from beatlog.record.recorder import Recorder
from beatlog.suite.coverage import select_exercising, suite_coverage
from beatlog.suite.spec import load_spec
from tests.commands import closing_counts
from tests.conftest import PERIOD_NS, Dice, Probe, RecordFn, distances, probe_system
from tests.specs import PROBE, write_spec
from tests.text import table_row, whole_lines


def _cover(dtcs: list[tuple[str, Path, System | None]]) -> SuiteCoverage:
    """The coverage of DTCs given as (id, log, a fresh system or None)."""
    recorded = [(dtc, read_changes(log), system) for dtc, log, system in dtcs]
    return cover_changes((d, r.system, r.changes, r.cycles, s) for d, r, s in recorded)


class Mood(enum.Enum):
    CALM = "calm"
    ALERT = "alert"
    ASLEEP = "asleep"


class Watchful:
    """Near, with declared states: it can sleep, but no recording makes it."""

    name = "watchful"
    states = Mood

    def __init__(self) -> None:
        self.state: BehaviorState = "calm"

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        self.state = "alert" if rs.distance < 0.5 else "calm"
        return None


def watchful_system() -> PriorityArbiter[Probe]:
    return PriorityArbiter([Watchful(), Dice()], robot_state=Probe)


def crossings(cycles: int) -> int:
    near = [d < 0.5 for d in distances(cycles)]
    return sum(1 for before, after in zip([False, *near], near, strict=False) if before != after)


def test_states_and_transitions_are_counted_with_dtcs_and_cycles(record_probe: RecordFn) -> None:
    log = record_probe(300)
    coverage = _cover([("approach", log, probe_system())])
    assert list(coverage.systems) == [PROBE]  # the one its log records
    near = coverage.systems[PROBE]["near"]
    far_to_near = near.transitions[('"far"', '"near"')]
    near_to_far = near.transitions[('"near"', '"far"')]
    assert far_to_near.dtcs == {"approach"}
    assert far_to_near.cycles + near_to_far.cycles == crossings(300)
    cycles_near = sum(d < 0.5 for d in distances(300))
    assert near.states['"near"'].cycles == cycles_near
    assert near.states['"far"'].cycles == 300 - cycles_near
    assert coverage.exercising("near") == ["approach"]


def test_a_declared_state_no_dtc_reaches_is_unreached(tmp_path: Path) -> None:
    log = tmp_path / "watch.beatlog"
    with Recorder(log, watchful_system(), seed=1, software="test") as recorder:
        for distance in distances(300):
            recorder.step(PERIOD_NS, Probe(distance=distance))
    assert declared_states(watchful_system()) == {"watchful": ('"calm"', '"alert"', '"asleep"')}
    coverage = _cover([("watch", log, watchful_system())])
    assert list(coverage.systems) == ["tests.conftest.Probe"]  # its log records no reference
    assert coverage.systems["tests.conftest.Probe"]["watchful"].unreached == ('"asleep"',)


class Moody(Watchful):
    """Watchful, whose state is a member of its Enum (logged as the member's value)."""

    def __init__(self) -> None:
        self.state = Mood.CALM  # type: ignore[assignment]

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        self.state = Mood.ALERT if rs.distance < 0.5 else Mood.CALM  # type: ignore[assignment]
        return None


def test_a_state_that_is_an_enum_member_counts_as_its_value(tmp_path: Path) -> None:
    log = tmp_path / "moody.beatlog"
    system = PriorityArbiter([Moody()], robot_state=Probe)
    with Recorder(log, system, seed=1, software="test") as recorder:
        for distance in distances(300):
            recorder.step(PERIOD_NS, Probe(distance=distance))
    moody = _cover([("moody", log, PriorityArbiter([Moody()], robot_state=Probe))])
    states = moody.systems["tests.conftest.Probe"]["watchful"].states
    assert set(states) == {'"calm"', '"alert"'}
    assert sum(seen.cycles for seen in states.values()) == 300


def test_coverage_adds_up_over_dtcs_and_selects_those_exercising_a_behavior(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    near_log = record_probe(300, name="near.beatlog")
    far_log = record_probe(40, name="far.beatlog", states=[Probe(distance=2.0)] * 40)
    approach = load_spec(write_spec(tmp_path, "approach", near_log, PROBE))
    idle = load_spec(write_spec(tmp_path, "idle", far_log, PROBE))
    coverage = suite_coverage([approach, idle])
    assert coverage.dtcs == ["approach.dtc.toml::approach", "idle.dtc.toml::idle"]
    near = coverage.systems[PROBE]["near"]
    assert near.states['"far"'].dtcs == {"approach.dtc.toml::approach", "idle.dtc.toml::idle"}
    assert coverage.exercising("near") == ["approach.dtc.toml::approach"]
    assert select_exercising([approach, idle], "near") == [approach]
    assert coverage.to_json()["systems"][PROBE]["near"]["unreached"] == []


def test_beatlog_test_shows_coverage_writes_json_and_runs_by_behavior(
    tmp_path: Path,
    record_probe: RecordFn,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("COLUMNS", "200")
    specs = tmp_path / "specs"
    write_spec(specs, "approach", record_probe(300, name="near.beatlog"), PROBE)
    far = record_probe(40, name="far.beatlog", states=[Probe(distance=2.0)] * 40)
    write_spec(specs, "idle", far, PROBE)
    report = tmp_path / "coverage.json"

    code = main(["test", "-j", "1", "--coverage", "--coverage-json", str(report), str(specs)])
    out = capsys.readouterr().out
    assert code == 0
    assert "transition coverage" in whole_lines(out)
    assert table_row(out, "near")[2] == '"far" → "near" ×3 in 1 DTC; "near" → "far" ×3 in 1 DTC'
    document = json.loads(report.read_text())
    assert document["dtcs"] == ["approach.dtc.toml::approach", "idle.dtc.toml::idle"]

    code = main(["test", "-j", "1", "--behavior", "near", str(specs)])
    out = capsys.readouterr().out
    assert code == 0
    assert closing_counts(out) == "1 passed, 0 failed"

    code = main(["test", "-j", "1", "--behavior", "nobody", str(specs)])
    err = capsys.readouterr().err
    assert code == 2
    assert err == (
        "beatlog: error: no DTC changes the state of behavior 'nobody'; "
        "they change arbiter, dice, near\n"
    )


def test_a_log_that_cannot_be_read_counts_nothing_and_the_others_still_count(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    broken = tmp_path / "broken.beatlog"
    broken.write_bytes(b"not a session log")
    approach = load_spec(write_spec(tmp_path, "approach", record_probe(300), PROBE))
    damaged = load_spec(write_spec(tmp_path, "damaged", broken, PROBE))

    coverage = suite_coverage([approach, damaged])

    assert coverage.dtcs == ["approach.dtc.toml::approach"]
    assert coverage.exercising("near") == ["approach.dtc.toml::approach"]
    assert select_exercising([approach, damaged], "near") == [approach, damaged]


def test_a_damaged_log_leaves_the_coverage_and_html_reports_of_the_others(
    tmp_path: Path,
    record_probe: RecordFn,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("COLUMNS", "200")
    specs, broken = tmp_path / "specs", tmp_path / "broken.beatlog"
    broken.write_bytes(b"not a session log")
    write_spec(specs, "approach", record_probe(300), PROBE)
    write_spec(specs, "damaged", broken, PROBE)
    html, report = tmp_path / "report.html", tmp_path / "coverage.json"

    reports = ["--coverage", "--coverage-json", str(report), "--html", str(html)]
    code = main(["test", "-j", "1", *reports, "--behavior", "near", str(specs)])

    captured = capsys.readouterr()
    assert code == 2
    assert captured.err.splitlines() == [
        f"beatlog: error: damaged ({specs / 'damaged.dtc.toml'}): "
        f"{specs / '..' / broken.name}: not a session log (not an MCAP file)"
    ]
    assert closing_counts(captured.out) == "1 passed, 0 failed, 1 error"
    assert json.loads(report.read_text())["dtcs"] == ["approach.dtc.toml::approach"]
    assert '<h2><span class="verdict">error</span> damaged</h2>' in whole_lines(html.read_text())
