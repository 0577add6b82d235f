"""Whole-session traces: the recorded one, and a replayed one that never stops early."""

from __future__ import annotations

import math
from unittest.mock import ANY

import numpy as np

from beatlog import replay
from beatlog.analysis.trace import recorded_outputs, recorded_trace, replayed_trace, whole_trace
from beatlog.replay.baseline import ABSENT, Baseline, OutputTracker, TracedOutput
from beatlog.replay.verdict import StateChange
from tests.conftest import RecordFn, probe_system, probe_system_renamed
from tests.specs import CHANGED


def test_replaying_the_recorded_system_gives_the_recorded_trace(record_probe: RecordFn) -> None:
    log = record_probe(300)
    recorded = recorded_trace(log)
    replayed = replayed_trace(log, probe_system())
    assert replayed.stopped is None
    assert replayed.cycles == 300
    assert list(replayed.changes) == recorded
    assert recorded[0].change.behavior in {"arbiter", "near", "dice"}
    assert [c.cycle for c in recorded] == sorted(c.cycle for c in recorded)


def test_a_changed_system_is_traced_to_the_end(record_probe: RecordFn) -> None:
    log = record_probe(300)
    replayed = replayed_trace(log, probe_system(threshold=0.6))
    assert replayed.stopped is None
    assert replayed.cycles == 300
    assert list(replayed.changes) != recorded_trace(log)


def test_a_renamed_system_traces_its_new_names(record_probe: RecordFn) -> None:
    replayed = replayed_trace(record_probe(100), probe_system_renamed())
    behaviors = {traced.change.behavior for traced in replayed.changes}
    assert behaviors == {"arbiter", "close", "dice"}
    assert StateChange("arbiter", "dice", "close") in [t.change for t in replayed.changes]


def test_a_trace_stops_where_the_behaviors_draw_numbers_the_log_lacks(
    record_probe: RecordFn,
) -> None:
    replayed = replayed_trace(record_probe(100), probe_system(draws=2))
    assert replayed.stopped == "cycle 0: dice called randint(1, 6) (#2) but only 1 were recorded"
    assert replayed.cycles == 0


def test_a_diverging_replay_by_reference_names_the_fields_read(record_probe: RecordFn) -> None:
    result = replay(record_probe(300), CHANGED)
    assert result.divergence is not None
    assert result.divergence.fields_read == ("distance",)


def test_outputs_are_traced_only_where_a_field_changes() -> None:
    tracker = OutputTracker()
    seen = [
        tracker.observe(0, 30, {"speed": 0.5, "turn": 0.0}),
        tracker.observe(1, 60, {"turn": 0.0, "speed": 0.5}),
        tracker.observe(2, 90, {"speed": -0.0}),
        tracker.observe(3, 120, {"speed": -0.0, "turn": np.float64(0.0)}),
        tracker.observe(4, 150, {}),
    ]
    assert seen == [
        [TracedOutput(0, 30, "speed", 0.5), TracedOutput(0, 30, "turn", 0.0)],
        [],
        [TracedOutput(2, 90, "speed", -0.0), TracedOutput(2, 90, "turn", ABSENT)],
        [TracedOutput(3, 120, "turn", 0.0)],
        [TracedOutput(4, 150, "speed", ABSENT), TracedOutput(4, 150, "turn", ABSENT)],
    ]
    assert math.copysign(1, seen[2][0].value) == -1  # -0.0 is a change from 0.5, kept exact


def test_replaying_the_recorded_system_gives_the_recorded_outputs(record_probe: RecordFn) -> None:
    log = record_probe(300)
    recorded = recorded_outputs(log)
    replayed = replayed_trace(log, probe_system())
    assert list(replayed.outputs) == recorded
    assert recorded[0] == TracedOutput(0, recorded[0].time_ns, "speed", 0.5)
    assert {o.field for o in recorded} == {"speed", "time"}
    assert any(o.value is ABSENT for o in recorded)  # near wins: no "time" output


def test_departures_applied_to_the_recording_give_back_the_whole_trace(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    replayed = replayed_trace(log, probe_system(threshold=0.6), match_draws=True)
    departures = replayed.baseline

    whole = whole_trace(departures, log)

    assert 0 < len(departures.outputs or ()) < len(replayed.outputs)
    assert (whole.changes, whole.outputs) == (replayed.changes, replayed.outputs)
    assert whole.baseline.open_loop == replayed.open_loop == (departures.changes[0].cycle, ANY)


def test_a_trace_as_recorded_departs_nowhere(record_probe: RecordFn) -> None:
    replayed = replayed_trace(record_probe(300), probe_system(), match_draws=True)
    assert replayed.baseline == Baseline(())
