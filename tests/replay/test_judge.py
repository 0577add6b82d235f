"""Replay (Algorithm 2): a recorded session passes until the behaviors change, and then
fails at exactly the first cycle that differs, saying what differed."""

from __future__ import annotations

import dataclasses
import inspect
import itertools
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import beatlog
from beatlog import DivergenceKind, StateChange, replay
from beatlog.analysis.trace import replayed_trace
from beatlog.errors import (
    CorruptLogError,
    EmptyCheckError,
    LogError,
    SchemaMismatchError,
    SystemLoadError,
    WindowError,
)
from beatlog.log.format import FORMAT_VERSION, SessionHeader
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.log.recording import Recording
from beatlog.log.writer import SessionLogWriter
from beatlog.model.behavior import BehaviorState, PriorityArbiter, System
from beatlog.model.context import Context, Outputs
from beatlog.model.state import RobotState
from beatlog.record.recorder import Recorder
from beatlog.replay import core, judge
from beatlog.replay.baseline import Baseline, TracedStateChange
from beatlog.replay.compare import Comparison
from beatlog.replay.fit.check import check_fit
from beatlog.replay.verdict import Checked
from tests.conftest import (
    PERIOD_NS,
    Dice,
    Near,
    Probe,
    RecordFn,
    distances,
    first_cycle_below,
    probe_system,
    probe_system_changed,
    probe_system_renamed,
)
from tests.crafting import chunks, drop_chunk
from tests.factories import (
    PROBE_CYCLE_DAMAGE,
    as_format_1,
    cut_in_half,
    logged_counts,
    rewrite_cycle,
    vouch,
)
from tests.systems import Fragile, dozy_system, impostor_system, quiet_system, record_session
from tests.text import frames, whole_lines


def test_a_recorded_session_replays_and_passes(record_probe: RecordFn) -> None:
    log = record_probe(300)
    result = replay(log, probe_system())
    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 300, "state_changes": 45, "outputs": 453, "draws": 60, "samples": 0},
    )
    assert result.robot_time_ns == sum(PERIOD_NS + (t % 3) * 1000 for t in range(300))
    assert result.status == LogStatus(complete=True, cycles=300)


def test_a_system_given_by_reference_replays_too(record_probe: RecordFn) -> None:
    log = record_probe(50)
    result = replay(log, "tests.conftest:probe_system")
    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 50, "state_changes": 9, "outputs": 76, "draws": 10, "samples": 0},
    )
    assert result.reproduce == f"beatlog replay {log} --system tests.conftest:probe_system"


def test_without_a_system_the_log_s_own_is_used_only_where_the_project_vouches_for_it(
    record_probe: RecordFn, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_probe(60)
    monkeypatch.chdir(tmp_path)

    with pytest.raises(SystemLoadError, match="which this project does not vouch for"):
        replay(log)

    vouch(tmp_path, "tests.conftest:probe_system")
    assert replay(log).ok


def test_a_changed_behavior_fails_at_the_first_cycle_it_acts_differently(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    result = replay(log, probe_system(threshold=0.6))
    divergence = result.divergence
    assert (result.ok, result.divergent_cycles) == (False, 1)
    assert divergence is not None
    expected_cycle = first_cycle_below(0.6)
    assert expected_cycle < first_cycle_below(0.5)
    assert divergence.kind is DivergenceKind.STATE_CHANGES
    assert divergence.cycle == expected_cycle
    assert result.cycles == expected_cycle + 1
    assert divergence.time_ns == sum(PERIOD_NS + (t % 3) * 1000 for t in range(expected_cycle + 1))
    assert divergence.expected == ()
    assert divergence.actual == (
        StateChange("arbiter", "dice", "near"),
        StateChange("near", "far", "near"),
    )
    assert divergence.behavior == "arbiter"
    assert divergence.robot_state["distance"] == distances(300)[expected_cycle]
    assert divergence.expected_outputs != divergence.actual_outputs


def test_drawing_more_random_numbers_than_recorded_is_caught(record_probe: RecordFn) -> None:
    result = replay(record_probe(50), probe_system(draws=2))
    divergence = result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.RANDOM_OVERDRAWN
    assert divergence.cycle == 0
    assert divergence.behavior == "dice"
    assert [d.kind for d in divergence.random_recorded] == ["randint"]
    drawn, refused = divergence.random_drawn
    assert (drawn.behavior, drawn.call, drawn.value) == (
        "dice",
        "randint(1, 6)",
        divergence.random_recorded[0].value,
    )
    assert (refused.behavior, refused.call, refused.value) == ("dice", "randint(1, 6)", None)
    assert str(refused) == "dice: randint(1, 6)"
    assert divergence.message == "dice called randint(1, 6) (#2) but only 1 were recorded"


def test_drawing_fewer_random_numbers_than_recorded_is_caught(record_probe: RecordFn) -> None:
    result = replay(record_probe(50), probe_system(every=10))
    divergence = result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.RANDOM_UNDERDRAWN
    assert divergence.cycle == 5
    assert divergence.behavior == "dice"
    assert (
        divergence.message
        == "drew 0 random numbers where 1 were recorded; the next recorded one was a randint drawn "
        "by dice"
    )


def test_an_exception_in_behavior_code_is_a_verdict_with_the_users_traceback(
    record_probe: RecordFn,
) -> None:
    system = PriorityArbiter([Near(), Fragile()], robot_state=Probe)
    result = replay(record_probe(300), system)
    divergence = result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.EXCEPTION
    assert divergence.cycle == first_cycle_below(0.3)
    assert divergence.behavior == "dice"
    assert divergence.traceback is not None
    assert (inspect.getsourcefile(Fragile), "step") in frames(divergence.traceback)
    assert 'raise ZeroDivisionError("fragile dice")' in whole_lines(divergence.traceback)
    assert str(Path(beatlog.__file__).parent) not in divergence.traceback  # no library frames


class Louder(Dice):
    """Dice that asks for a different speed: only its outputs change."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        outputs = super().step(rs, ctx)
        assert outputs is not None
        return {**outputs, "speed": 0.75}


def test_changed_outputs_alone_are_a_divergence(record_probe: RecordFn) -> None:
    result = replay(record_probe(20), PriorityArbiter([Near(), Louder()], robot_state=Probe))
    divergence = result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.OUTPUTS
    assert divergence.cycle == 0
    assert divergence.expected_outputs["speed"] == 0.5
    assert divergence.actual_outputs["speed"] == 0.75


class Listed:
    """A system with the catalogue of another listed in a different order."""

    def __init__(self, system: PriorityArbiter[Probe], order: list[str]) -> None:
        self.system = system
        self.behaviors = {name: system.behaviors[name] for name in order}
        self.robot_state = Probe

    def update(self, state: Probe, context: Context) -> None:
        self.system.update(state, context)


BACKWARDS = ["dice", "near", "arbiter"]


def test_a_system_listing_its_behaviors_in_another_order_passes(record_probe: RecordFn) -> None:
    log = record_probe(300)
    assert replay(log, Listed(probe_system(), BACKWARDS)).ok


def test_a_real_change_fails_whatever_order_the_behaviors_are_listed_in(
    record_probe: RecordFn,
) -> None:
    result = replay(record_probe(300), Listed(probe_system(threshold=0.6), BACKWARDS))
    divergence = result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.STATE_CHANGES
    assert divergence.cycle == first_cycle_below(0.6)
    assert divergence.behavior == "near"
    assert divergence.message == "behavior state changes differ from the recording"


class Gentle(Near):
    """Near that asks for a different speed: only its outputs change."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        return None if super().step(rs, ctx) is None else {"speed": 0.1}


def test_a_divergence_says_when_a_cycles_state_changes_differ_only_in_order(
    record_probe: RecordFn,
) -> None:
    system = Listed(PriorityArbiter([Gentle(), Dice()], robot_state=Probe), BACKWARDS)
    divergence = replay(record_probe(300), system).divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.OUTPUTS
    assert divergence.cycle == first_cycle_below(0.5)
    assert [change.behavior for change in divergence.expected] == ["arbiter", "near"]
    assert [change.behavior for change in divergence.actual] == ["near", "arbiter"]
    assert (
        divergence.message
        == "outputs differ from the recording; the state changes differ only in the order "
        "behaviors are listed, which is no difference"
    )


def test_keep_going_counts_every_diverging_cycle(record_probe: RecordFn) -> None:
    log = record_probe(300)
    first = replay(log, probe_system(threshold=0.6))
    every = replay(log, probe_system(threshold=0.6), keep_going=True)
    assert every.cycles == 300
    assert every.divergence is not None
    assert first.divergence is not None
    assert dataclasses.replace(every.divergence, context=()) == dataclasses.replace(
        first.divergence, context=()
    )
    assert first.divergence.context[: len(every.divergence.context)] == every.divergence.context
    assert first.divergent_cycles == 1
    assert every.divergent_cycles > 1


def test_the_same_log_replays_to_the_same_result_every_time(record_probe: RecordFn) -> None:
    log = record_probe(300)
    for threshold in (0.5, 0.6):
        first = replay(log, probe_system(threshold))
        second = replay(log, probe_system(threshold))
        assert dataclasses.replace(first, wall_time_s=0) == dataclasses.replace(
            second, wall_time_s=0
        )


class Die(Dice):
    name = "die"


def test_a_renamed_behavior_is_compared_by_name(record_probe: RecordFn) -> None:
    result = replay(record_probe(50), PriorityArbiter([Near(), Die()], robot_state=Probe))
    divergence = result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.STATE_CHANGES
    assert divergence.cycle == 0
    assert StateChange("arbiter", "idle", "dice") in divergence.expected
    assert StateChange("arbiter", "idle", "die") in divergence.actual


class Other(RobotState, kw_only=True):
    distance: str = "far"


class Unused:
    name = "unused"
    state: BehaviorState = "idle"

    def step(self, rs: Other, ctx: Context) -> Outputs | None:
        return None


def test_a_robot_state_that_does_not_fit_the_system_is_bad_input(record_probe: RecordFn) -> None:
    log = record_probe(5)
    with pytest.raises(SchemaMismatchError, match=r"probe\.beatlog: recorded with robot state"):
        replay(log, PriorityArbiter([Unused()], robot_state=Other))


class Clocked:
    """Reports time and dt as outputs so the test can see what behaviors were told."""

    name = "clocked"
    state: BehaviorState = "on"

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        return {"time_ns": ctx.time_ns, "dt": ctx.dt, "cycle": ctx.cycle}


def test_behaviors_see_the_recorded_heartbeat_time(tmp_path: Path, record_probe: RecordFn) -> None:
    log = tmp_path / "clocked.beatlog"
    intervals = [30_000_000, 31_500_000, 29_000_000, 45_000_000]
    seen = []
    with Recorder(log, PriorityArbiter([Clocked()], robot_state=Probe), software="t") as rec:
        for interval in intervals:
            seen.append(dict(rec.step(interval, Probe())))
    assert [s["time_ns"] for s in seen] == [30_000_000, 61_500_000, 90_500_000, 135_500_000]
    assert seen[3]["dt"] == 0.045
    assert replay(log, PriorityArbiter([Clocked()], robot_state=Probe)).ok


def test_a_truncated_log_fails_as_ending_early_unless_allowed(record_probe: RecordFn) -> None:
    log = record_probe(300, flush_interval_s=1.0)
    data = log.read_bytes()
    cut = log.with_name("cut.beatlog")
    cut.write_bytes(data[: len(data) - 200])
    result = replay(cut, probe_system())
    divergence = result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.LOG_ENDED
    assert result.status is not None
    assert (result.status.complete, result.status.cycles) == (False, divergence.cycle)
    assert re.fullmatch(
        rf"the log ends early \(truncated at cycle {divergence.cycle}: the last record is cut off "
        r"at byte \d+\); if the session ended there \(a crash\), accept what it holds with "
        r"--allow-truncated \(in a spec: allow_truncated = true\)",
        divergence.message,
    ), divergence.message
    allowed = replay(cut, probe_system(), allow_truncated=True)
    assert (allowed.ok, allowed.divergence, allowed.counts) == (
        True,
        None,
        {"cycles": 300, "state_changes": 45, "outputs": 453, "draws": 60, "samples": 0},
    )
    assert allowed.cycles == result.cycles


class Numpy:
    """Emits numpy values, as behaviors doing vector maths do."""

    name = "numpy"
    state: BehaviorState = "on"

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        return {"gain": np.float32(rs.distance), "wheels": np.arange(2, dtype=np.int64)}


def test_numpy_outputs_are_recorded_and_compared(tmp_path: Path) -> None:
    log = tmp_path / "numpy.beatlog"
    with Recorder(log, PriorityArbiter([Numpy()], robot_state=Probe), software="t") as rec:
        for distance in (0.25, 0.5, 1.0):
            rec.step(PERIOD_NS, Probe(distance=distance))
    assert replay(log, PriorityArbiter([Numpy()], robot_state=Probe)).ok


def test_damaged_random_numbers_in_a_log_are_bad_input(tmp_path: Path) -> None:
    log = tmp_path / "hostile.beatlog"
    system = probe_system()
    header = SessionHeader(
        format_version=FORMAT_VERSION,
        beatlog_version="test",
        robot_id="r",
        software_version="t",
        system="",
        period_ns=PERIOD_NS,
        start_time_ns=0,
        robot_state_type="tests.conftest.Probe",
        robot_state_schema={},
        behaviors=list(system.behaviors),
    )
    with SessionLogWriter(log, header) as writer:
        writer.append(PERIOD_NS, Probe(), [], ["not a draw"], {})
    with pytest.raises(CorruptLogError, match="damaged random numbers in cycle"):
        replay(log, system)


class Unrecordable(Dice):
    """Emits an output that cannot be put into a log."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        super().step(rs, ctx)
        return {"speed": object()}


def test_an_output_that_cannot_be_logged_is_a_verdict(record_probe: RecordFn) -> None:
    log = record_probe(5)
    result = replay(log, PriorityArbiter([Near(), Unrecordable()], robot_state=Probe))
    divergence = result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.EXCEPTION
    assert divergence.message == "arbiter raised TypeError: cannot record a value of type object"
    assert result.reproduce == f"beatlog replay {log} --system tests.conftest:probe_system"


def test_a_divergence_shows_the_cycles_around_it(record_probe: RecordFn) -> None:
    log = record_probe(300)
    divergence = replay(log, probe_system(threshold=0.6), context_cycles=30).divergence
    assert divergence is not None
    assert divergence.cycle == 21
    # the cycles within 30 of it that it shows, and whether recording and replay agree there
    assert [(row.cycle, row.expected == row.actual) for row in divergence.context] == [
        (0, True),
        (10, True),
        (15, True),
        (21, False),
        (26, False),
        (35, True),
        (40, True),
        (45, True),
    ]
    intervals = [PERIOD_NS + (t % 3) * 1000 for t in range(300)]
    for row in divergence.context:
        assert row.time_ns == sum(intervals[: row.cycle + 1])


def test_a_renamed_behavior_fails_and_the_rename_is_proposed(record_probe: RecordFn) -> None:
    result = replay(record_probe(300), probe_system_renamed())
    assert result.divergence is not None
    assert result.divergence.kind is DivergenceKind.STATE_CHANGES
    assert result.divergence.proposed_renames == {"near": "close"}


def test_a_renamed_behavior_passes_under_the_rename(record_probe: RecordFn) -> None:
    result = replay(
        record_probe(300), probe_system_renamed(), comparison=Comparison(renames={"near": "close"})
    )
    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 300, "state_changes": 45, "outputs": 453, "draws": 60, "samples": 0},
    )


def test_a_real_change_under_new_names_proposes_no_rename(record_probe: RecordFn) -> None:
    system = probe_system_renamed()
    system.behaviors["close"].threshold = 0.6  # type: ignore[attr-defined]
    result = replay(record_probe(300), system)
    assert result.divergence is not None
    assert result.divergence.proposed_renames == {}


def test_an_ignored_behavior_may_change(record_probe: RecordFn) -> None:
    log = record_probe(300)
    changed = replay(log, probe_system(threshold=0.6), comparison=Comparison(
        ignore_behaviors=frozenset({"near", "arbiter"}), ignore_fields=("speed", "time")
    ))  # fmt: skip
    assert (changed.ok, changed.divergence, changed.counts) == (
        True,
        None,
        {"cycles": 300, "state_changes": 45, "outputs": 423, "draws": 60, "samples": 0},
    )
    assert not replay(log, probe_system(threshold=0.6)).ok


def test_an_output_tolerance_accepts_a_small_drift(record_probe: RecordFn) -> None:
    class Drifting(Dice):
        def step(self, rs: Probe, ctx: Context) -> Outputs | None:
            outputs = super().step(rs, ctx)
            assert outputs is not None
            return {**outputs, "speed": outputs["speed"] + 1e-9}

    log = record_probe(100)
    system = PriorityArbiter([Near(), Drifting()], robot_state=Probe)
    result = replay(log, system, comparison=Comparison(tolerance={"speed": 1e-6}))
    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 100, "state_changes": 15, "outputs": 151, "draws": 20, "samples": 0},
    )
    strict = replay(log, PriorityArbiter([Near(), Drifting()], robot_state=Probe))
    assert strict.divergence is not None
    assert strict.divergence.kind is DivergenceKind.OUTPUTS


def test_an_approved_baseline_replaces_the_recorded_state_changes(record_probe: RecordFn) -> None:
    log = record_probe(300)
    baseline = replayed_trace(log, probe_system(threshold=0.6)).baseline
    assert replay(log, probe_system(threshold=0.6), baseline=baseline).ok
    old = replay(log, probe_system(), baseline=baseline)
    assert old.divergence is not None
    assert old.divergence.message == "behavior state changes differ from the approved baseline"
    assert old.divergence.cycle == first_cycle_below(0.6)


def test_a_baseline_naming_unknown_behaviors_fails_naming_them(record_probe: RecordFn) -> None:
    log = record_probe(50)
    trace = replayed_trace(log, probe_system())
    ghost = TracedStateChange(3, 0, StateChange("ghost", "a", "b"))
    baseline = Baseline((ghost, *trace.changes), trace.outputs)
    result = replay(log, probe_system(), baseline=baseline)
    assert result.divergence is not None
    assert result.divergence.cycle == 3
    assert StateChange("ghost", "a", "b") in result.divergence.expected


class Geared(Dice):
    """Dice with a new motor gain once the obstacle is within 0.8: only outputs change."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        outputs = super().step(rs, ctx)
        assert outputs is not None
        return {**outputs, "speed": 0.55 if rs.distance < 0.8 else 0.5}


def geared_system(threshold: float = 0.6) -> PriorityArbiter[Probe]:
    return PriorityArbiter([Near(threshold), Geared()], robot_state=Probe)


def test_an_approved_baseline_still_pins_the_outputs(record_probe: RecordFn) -> None:
    log = record_probe(300)
    baseline = replayed_trace(log, probe_system(threshold=0.6)).baseline
    assert len(baseline.outputs or ()) == 12

    result = replay(log, geared_system(), baseline=baseline)

    divergence = result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.OUTPUTS
    assert divergence.message == "outputs differ from the approved baseline"
    assert divergence.cycle == first_cycle_below(0.8)
    assert divergence.expected_outputs["speed"] == 0.5
    assert divergence.actual_outputs["speed"] == 0.55


def test_a_baseline_s_outputs_are_judged_with_the_spec_allowances(record_probe: RecordFn) -> None:
    log = record_probe(300)
    baseline = replayed_trace(log, probe_system(threshold=0.6)).baseline
    for allowance in (Comparison(ignore_fields=("sp*",)), Comparison(tolerance={"speed": 0.1})):
        result = replay(log, geared_system(), baseline=baseline, comparison=allowance)
        assert (result.ok, result.divergence, result.counts) == (
            True,
            None,
            {"cycles": 300, "state_changes": 45, "outputs": 423, "draws": 60, "samples": 0},
        )
    tight = replay(log, geared_system(), baseline=baseline, comparison=Comparison(
        tolerance={"speed": 0.01}
    ))  # fmt: skip
    assert tight.divergence is not None
    assert tight.divergence.kind is DivergenceKind.OUTPUTS


def test_outputs_reported_in_another_order_match_the_baseline(record_probe: RecordFn) -> None:
    class Reordered(Dice):
        def step(self, rs: Probe, ctx: Context) -> Outputs | None:
            outputs = super().step(rs, ctx)
            assert outputs is not None
            return dict(reversed(outputs.items()))

    log = record_probe(100)
    baseline = replayed_trace(log, probe_system()).baseline
    system = PriorityArbiter([Near(), Reordered()], robot_state=Probe)
    assert replay(log, system, baseline=baseline).ok


def test_the_reproduce_command_carries_the_replay_options(tmp_path: Path) -> None:
    log = tmp_path / "a session.beatlog"
    with Recorder(log, probe_system(), seed=1, system_ref="tests.conftest:probe_system") as rec:
        for t in range(30):
            rec.step(PERIOD_NS, Probe(distance=distances(30)[t]))
    result = replay(
        log, probe_system(threshold=0.9), keep_going=True, allow_truncated=True, allow_empty=True
    )
    assert result.reproduce == (
        f"beatlog replay '{log}' --system tests.conftest:probe_system "
        "--keep-going --allow-truncated --allow-empty"
    )


class Quitter(Dice):
    """Dice that calls sys.exit on a close obstacle."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        if rs.distance < 0.3:
            raise SystemExit(3)
        return super().step(rs, ctx)


def test_a_behavior_that_calls_sys_exit_is_an_exception_verdict(record_probe: RecordFn) -> None:
    result = replay(record_probe(300), PriorityArbiter([Near(), Quitter()], robot_state=Probe))
    assert result.divergence is not None
    assert result.divergence.kind is DivergenceKind.EXCEPTION
    assert result.divergence.message == "dice raised SystemExit: 3"


def test_a_log_damaged_after_the_first_divergence_is_still_bad_input(
    record_probe: RecordFn,
) -> None:
    log = record_probe(3000, flush_interval_s=0.5)
    data = log.read_bytes()
    log.write_bytes(drop_chunk(data, chunks(data)[-1]))
    with pytest.raises(LogError):
        replay(log, probe_system_changed())


def test_a_format_1_log_still_replays_and_still_catches_a_change(
    record_probe: RecordFn, tmp_path: Path
) -> None:
    old = as_format_1(record_probe(300), tmp_path / "format-1.beatlog")
    with SessionLogReader(old) as reader:
        assert reader.format_version == 1
    assert replay(old, probe_system()).ok
    divergence = replay(old, probe_system_changed()).divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.STATE_CHANGES


# what a replay checked


def test_a_pass_counts_what_it_checked(record_probe: RecordFn) -> None:
    log = record_probe(300)

    result = replay(log, probe_system())

    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 300, "state_changes": 45, "outputs": 453, "draws": 60, "samples": 0},
    )
    assert result.checked == logged_counts(log)
    assert result.checked.draws == 60  # dice draws every fifth cycle
    assert result.counts == {
        "cycles": 300,
        "state_changes": result.checked.state_changes,
        "outputs": result.checked.outputs,
        "draws": 60,
        "samples": 0,
    }


def test_a_divergence_counts_only_the_cycles_before_it(record_probe: RecordFn) -> None:
    log = record_probe(300)
    first = first_cycle_below(0.6)

    result = replay(log, probe_system_changed())

    assert result.cycles == first + 1
    assert result.checked == logged_counts(log, first)


def test_keep_going_counts_the_cycles_that_agreed(record_probe: RecordFn) -> None:
    log = record_probe(300)

    result = replay(log, probe_system(every=300), keep_going=True)

    # dice now draws in cycle 0 alone: every other fifth cycle diverges, and checks nothing
    assert result.divergent_cycles == 59
    assert result.checked.draws == 1


def test_a_log_without_a_cycle_is_refused_as_checking_nothing(tmp_path: Path) -> None:
    log = tmp_path / "nothing.beatlog"
    Recorder(log, probe_system(), software="test").close()

    with pytest.raises(EmptyCheckError) as refused:
        replay(log, probe_system())

    assert str(refused.value) == (
        f"{log}: the replay checked nothing (0 cycles); if nothing is meant to happen in "
        "it, accept it with --allow-empty (in a spec: allow_empty = true)"
    )


def test_a_log_killed_before_its_first_cycle_is_no_pass_even_when_truncation_is_allowed(
    tmp_path: Path,
) -> None:
    log = tmp_path / "killed.beatlog"
    with Recorder(tmp_path / "live.beatlog", probe_system(), software="test"):
        log.write_bytes((tmp_path / "live.beatlog").read_bytes())

    ended = replay(log, probe_system()).divergence
    with pytest.raises(EmptyCheckError, match=r"checked nothing \(0 cycles\)"):
        replay(log, probe_system(), allow_truncated=True)

    assert ended is not None
    assert ended.kind is DivergenceKind.LOG_ENDED


def test_a_session_in_which_nothing_happens_is_refused_as_checking_nothing(
    tmp_path: Path,
) -> None:
    log = record_session(tmp_path / "quiet.beatlog", quiet_system(), cycles=20)

    with pytest.raises(EmptyCheckError) as refused:
        replay(log, quiet_system())

    assert refused.value.problem == (
        "the replay checked nothing (20 cycles but no state change, output, draw or "
        "sample); if nothing is meant to happen in it, accept it with --allow-empty (in a "
        "spec: allow_empty = true)"
    )


def test_an_empty_check_passes_when_allowed(tmp_path: Path) -> None:
    log = record_session(tmp_path / "quiet.beatlog", quiet_system(), cycles=20)

    result = replay(log, quiet_system(), allow_empty=True)

    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 20, "state_changes": 0, "outputs": 0, "draws": 0, "samples": 0},
    )
    assert (result.cycles, result.checked) == (20, Checked())


@pytest.mark.parametrize("name", PROBE_CYCLE_DAMAGE)
@pytest.mark.parametrize("how", ["plain", "observed", "keep-going"])
def test_a_cycle_not_as_the_header_declares_is_damage_however_it_is_replayed(
    tmp_path: Path, record_probe: RecordFn, name: str, how: str
) -> None:
    damage = PROBE_CYCLE_DAMAGE[name]
    log = rewrite_cycle(record_probe(60), tmp_path / f"{name}.beatlog", damage.cycle, damage.edit)
    observe = (lambda outcome: None) if how == "observed" else None

    with pytest.raises(LogError) as raised:
        replay(log, probe_system(), keep_going=how == "keep-going", observe=observe)

    assert str(raised.value) == f"{log}: {damage.problem}"


class Noisy:
    """Draws an array of three normal numbers every cycle."""

    name = "noisy"
    state: BehaviorState = "quiet"

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        return {"noise": float(ctx.random.normal_array(0.0, 1.0, 3).sum())}


def test_a_damaged_array_draw_is_damage_not_the_behavior_failing(tmp_path: Path) -> None:
    log = tmp_path / "noisy.beatlog"
    with Recorder(log, PriorityArbiter([Noisy()], robot_state=Probe), software="t") as recorder:
        for _ in range(5):
            recorder.step(PERIOD_NS, Probe())

    def cut_short(parts: list[Any]) -> list[Any]:
        [[actor, kind, [dtype, shape, data], params]] = parts[3]
        return [*parts[:3], [[actor, kind, [dtype, shape, data[:-8]], params]], *parts[4:]]

    damaged = rewrite_cycle(log, tmp_path / "damaged.beatlog", 2, cut_short)
    with pytest.raises(CorruptLogError) as raised:
        replay(damaged, PriorityArbiter([Noisy()], robot_state=Probe))

    assert str(raised.value) == (
        f"{damaged}: damaged random number #1 in cycle 2: "
        "normal_array recorded 16 bytes for shape [3], not 24"
    )


@pytest.mark.parametrize(
    ("system", "cycles", "expected"),
    [
        (
            dozy_system,
            100,
            (
                10,
                DivergenceKind.STATE_CHANGES,
                "dice",
                "behavior state changes differ from the recording, and then the behaviors drew 0 "
                "random numbers where 1 were recorded; the next recorded one was a randint drawn "
                "by dice",
            ),
        ),
        (
            impostor_system,
            60,
            (
                0,
                DivergenceKind.RANDOM_MISMATCH,
                "near",
                "near called randint(1, 6), which dice drew in the recording",
            ),
        ),
    ],
    ids=["a draw skipped: headlined as the behavior change", "a draw credited to another"],
)
def test_a_draw_that_differs_from_the_recording_is_headlined_by_what_changed_first(
    record_probe: RecordFn,
    system: Callable[[], System],
    cycles: int,
    expected: tuple[int, DivergenceKind, str, str],
) -> None:
    divergence = replay(record_probe(cycles), system()).divergence

    assert divergence is not None
    assert (divergence.cycle, divergence.kind, divergence.behavior, divergence.message) == expected


def test_draws_are_matched_to_behaviors_by_name_not_by_position(record_probe: RecordFn) -> None:
    swapped = PriorityArbiter([Dice(), Near()], robot_state=Probe)  # dice is #1 now, was #2

    result = replay(record_probe(60), swapped)

    assert result.divergence is not None  # near's change of control, not dice's draws
    assert (result.divergence.cycle, result.divergence.kind) == (
        first_cycle_below(0.5),
        DivergenceKind.STATE_CHANGES,
    )


def test_the_wall_time_counts_opening_and_checking_the_log(
    record_probe: RecordFn, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_probe(30)
    system = probe_system()
    checked: list[bool] = []

    def slow_check(*args: Any, **options: Any) -> None:
        checked.append(True)
        time.sleep(0.05)  # a wide robot state's schema takes a while to compare
        check_fit(*args, **options)

    monkeypatch.setattr(core, "check_fit", slow_check)
    result = replay(log, system)
    assert checked == [True]
    assert result.wall_time_s >= 0.05


# a window of cycles


def test_a_window_judges_its_cycles_alone(record_probe: RecordFn) -> None:
    log = record_probe(300)
    assert not replay(log, probe_system_changed()).ok  # it diverges before cycle 30

    result = replay(log, probe_system_changed(), start_cycle=30, end_cycle=60)

    assert result.ok
    assert result.cycles == 31
    assert result.notes == (
        "30 cycles before the window replayed as recorded to rebuild the state, unjudged",
    )
    upto_end, before = logged_counts(log, 61), logged_counts(log, 30)
    assert result.checked == Checked(
        *(
            a - b
            for a, b in zip(dataclasses.astuple(upto_end), dataclasses.astuple(before), strict=True)
        )
    )


def test_a_divergence_in_the_window_fails_it_where_it_comes(record_probe: RecordFn) -> None:
    log = record_probe(300)
    changed = next(t for t, d in enumerate(distances(300)) if t >= 30 and (d < 0.6) != (d < 0.5))

    result = replay(log, probe_system_changed(), start_cycle=30, end_cycle=200)

    assert result.divergence is not None
    assert result.divergence.kind is DivergenceKind.STATE_CHANGES
    assert result.divergence.cycle == changed
    assert result.reproduce.endswith("--start-cycle 30 --end-cycle 200")


def test_a_behavior_that_raises_before_the_window_fails_it_there(record_probe: RecordFn) -> None:
    log = record_probe(300)
    fragile = "tests.systems:fragile_system"
    cycle = first_cycle_below(0.3)

    result = replay(log, fragile, start_cycle=cycle + 10, end_cycle=cycle + 20, explain=False)

    assert result.divergence is not None
    assert result.divergence.kind is DivergenceKind.EXCEPTION
    assert result.divergence.cycle == cycle
    assert result.divergence.message == (
        f"before the window (cycle {cycle + 10} on): dice raised ZeroDivisionError: fragile dice"
    )


def test_a_windowed_replay_reads_the_log_no_further_than_its_end(
    record_chunked: RecordFn,
) -> None:
    recording = Recording(record_chunked(300))
    read: list[int] = []

    class Counting:
        def __init__(self, reader: SessionLogReader) -> None:
            pass

        def read(self, batch: Any) -> None:
            read.append(len(batch))

    result = judge.replay(recording, probe_system(), end_cycle=44, readers=[Counting])

    assert result.ok
    assert result.cycles == 45
    assert result.status is None  # its end never read
    assert sum(read[:-1]) <= 44 < sum(read)  # the last batch read holds cycle 44
    assert recording.digest is None  # the file was not read to its end


def test_a_windowed_replay_still_finds_damage_in_what_it_reads(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    damage = PROBE_CYCLE_DAMAGE["robot-state-empty"]
    log = rewrite_cycle(record_probe(60), tmp_path / "damaged.beatlog", damage.cycle, damage.edit)

    with pytest.raises(LogError) as raised:
        replay(log, probe_system(), start_cycle=damage.cycle + 1, end_cycle=damage.cycle + 2)

    assert str(raised.value) == f"{log}: {damage.problem}"


@pytest.mark.parametrize(("key", "window"), [("end_cycle", (0, 300)), ("start_cycle", (300, None))])
def test_a_window_past_the_logs_last_cycle_is_an_error(
    record_probe: RecordFn, key: str, window: tuple[int, int | None]
) -> None:
    log = record_probe(300)
    start, end = window

    with pytest.raises(WindowError) as raised:
        replay(log, probe_system(), start_cycle=start, end_cycle=end)

    assert str(raised.value) == f"{log}: {key} 300 is past the log's last cycle (299)"


# a window from a fresh start


class Noting(Dice):
    """Dice that notes each cycle it steps in and the robot time it sees there."""

    def __init__(self, seen: list[tuple[int, int]]) -> None:
        super().__init__()
        self.seen = seen

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        self.seen.append((ctx.cycle, ctx.time_ns))
        return super().step(rs, ctx)


def recorded_times(log: Path) -> list[int]:
    """The robot time at the end of each cycle of ``log``, as recorded."""
    with SessionLogReader(log) as reader:
        return list(itertools.accumulate(cycle.heartbeat_ns for cycle in reader.cycles()))


def test_a_fresh_start_steps_the_windows_cycles_alone_at_their_recorded_times(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    seen: list[tuple[int, int]] = []
    system = PriorityArbiter([Near(), Noting(seen)], robot_state=Probe)

    result = replay(log, system, start_cycle=200, end_cycle=220, fresh_start=True, keep_going=True)

    times = recorded_times(log)
    assert seen == [(cycle, times[cycle]) for cycle in range(200, 221)]
    assert result.cycles == 21
    assert result.robot_time_ns == times[220] - times[199]
    assert result.notes == (
        "fresh start: the behaviors start from rest at cycle 200; "
        "200 cycles before it not replayed",
    )
    assert result.reproduce.endswith("--start-cycle 200 --end-cycle 220 --fresh-start")


def test_a_fresh_start_fails_where_its_window_fails_with_the_recorded_cycle_and_time(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    cycle = first_cycle_below(0.3) + 200  # the third approach

    result = replay(log, "tests.systems:fragile_system", start_cycle=cycle, fresh_start=True)

    assert result.divergence is not None
    assert (result.divergence.kind, result.divergence.behavior) == (
        DivergenceKind.EXCEPTION,
        "dice",
    )
    assert (result.divergence.cycle, result.divergence.time_ns) == (
        cycle,
        recorded_times(log)[cycle],
    )
    assert result.divergence.fields_read == ("distance",)


@pytest.mark.parametrize(
    "damage",
    [
        lambda data: drop_chunk(data, chunks(data)[3]),
        lambda data: flip_byte(data, chunks(data)[3].offset + 60),
    ],
    ids=["chunk-dropped", "chunk-damaged"],
)
def test_a_log_damaged_before_a_fresh_start_is_still_bad_input(
    record_chunked: RecordFn, damage: Callable[[bytes], bytes]
) -> None:
    log = record_chunked(300)
    log.write_bytes(damage(log.read_bytes()))

    with pytest.raises(CorruptLogError):
        replay(log, probe_system(), start_cycle=200, end_cycle=220, fresh_start=True)


def flip_byte(data: bytes, at: int) -> bytes:
    """``data`` with the byte at ``at`` inverted."""
    return data[:at] + bytes([data[at] ^ 0xFF]) + data[at + 1 :]


def test_a_fresh_start_is_judged_against_an_approved_baseline_from_its_own_cycle(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    baseline = replayed_trace(log, probe_system_changed()).baseline

    result = replay(
        log,
        probe_system_changed(),
        baseline=baseline,
        start_cycle=150,
        end_cycle=299,
        fresh_start=True,
        keep_going=True,
    )

    assert result.ok  # the fresh behaviors' states are the expected ones there
    assert result.cycles == 150


def test_a_fresh_start_finds_the_state_changes_against_the_recorded_states(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    drawn = 150  # dice draws here: its fresh state is then the recorded one
    assert replay(log, probe_system(), start_cycle=drawn, fresh_start=True).ok

    result = replay(log, probe_system(), start_cycle=drawn - 2, fresh_start=True)

    assert result.divergence is not None  # the fresh dice has not rolled yet
    assert (result.divergence.kind, result.divergence.behavior) == (
        DivergenceKind.STATE_CHANGES,
        "dice",
    )


def test_a_log_cut_off_before_a_fresh_start_ends_where_it_was_cut(
    record_chunked: RecordFn,
) -> None:
    log = cut_in_half(record_chunked(300))
    with SessionLogReader(log) as reader:
        for _ in reader.batches():
            pass
        cycles = reader.status.cycles

    result = replay(log, probe_system(), start_cycle=cycles + 20, fresh_start=True)

    assert result.divergence is not None
    assert (result.divergence.kind, result.divergence.cycle) == (DivergenceKind.LOG_ENDED, cycles)


@pytest.mark.parametrize(
    ("threshold", "draws", "keep_going"),
    [(0.5, 1, False), (0.6, 1, False), (0.6, 1, True), (0.5, 2, False)],
    ids=["passes", "diverges", "keeps-going", "draws-otherwise"],
)
def test_robot_states_decoded_with_their_batch_judge_as_decoded_cycle_by_cycle(
    record_probe: RecordFn, threshold: float, draws: int, keep_going: bool
) -> None:
    """Without observers the reader decodes RS_t with each batch; with one, cycle by cycle."""
    log = record_probe(300)

    alone = replay(log, probe_system(threshold, draws=draws), keep_going=keep_going)
    observed = replay(
        log, probe_system(threshold, draws=draws), keep_going=keep_going, observe=lambda o: None
    )

    assert (alone.ok, alone.divergence, alone.divergent_cycles, alone.counts) == (
        observed.ok,
        observed.divergence,
        observed.divergent_cycles,
        observed.counts,
    )
