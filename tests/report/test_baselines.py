"""The re-baselining workflow in words: one line per pending file touched, saying how to
go on, the same for the terminal and the pytest summary."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.replaying.verdict import FieldDifference
from beatlog.report.baselines import render_orphans, render_pending_diff, render_updates
from beatlog.report.console import plain_text
from beatlog.suite.maintenance import PendingDiff, PendingUpdate, RebuiltRun, UpdateAction
from beatlog.suite.spec import DtcSpec

SPEC = DtcSpec(
    path=Path("specs/avoid-pole.dtc.toml"),
    name="avoid-pole",
    purpose="The probe stops near the pole.",
    procedure=("Drive the probe toward the pole.",),
    log=Path("specs/probe.beatlog"),
    system="tests.conftest:probe_system",
)
PENDING = Path("specs/avoid-pole.dtc.pending")

LINES = {
    UpdateAction.WRITTEN: "pending specs/avoid-pole.dtc.pending (3 state changes, 5 output "
    "changes): review with beatlog review specs/avoid-pole.dtc.toml, accept with "
    "beatlog approve specs/avoid-pole.dtc.toml",
    UpdateAction.WITHHELD: "CI is set: no pending baselines written",
    UpdateAction.REFUSED: "not updated avoid-pole: re-record the session",
    UpdateAction.REMOVED: "removed stale specs/avoid-pole.dtc.pending: avoid-pole passes",
}


@pytest.mark.parametrize("action", list(UpdateAction))
def test_each_update_action_is_one_line(action: UpdateAction) -> None:
    reason = "re-record the session" if action is UpdateAction.REFUSED else None
    update = PendingUpdate(SPEC, action, PENDING, 3, 5, reason)

    assert [line.plain for line in render_updates([update])] == [LINES[action]]


def test_withheld_updates_are_said_once() -> None:
    withheld = [PendingUpdate(SPEC, UpdateAction.WITHHELD, PENDING)] * 3
    assert [line.plain for line in render_updates(withheld)] == [LINES[UpdateAction.WITHHELD]]


def test_each_orphan_is_named() -> None:
    lines = render_orphans([Path("specs/gone.dtc.expected")])
    assert [line.plain for line in lines] == [
        "orphaned baseline specs/gone.dtc.expected: no spec beside it; delete it"
    ]


def test_a_long_diff_is_cut_and_says_where_the_rest_is() -> None:
    lines = ("--- recorded (probe.beatlog)", "+++ pending", *(f"+{n}" for n in range(10)))
    diff = PendingDiff(SPEC, "recorded (probe.beatlog)", 0, 10, lines)

    text = plain_text(render_pending_diff(diff, max_lines=4))

    assert text.splitlines()[1:] == [
        "0 state and output changes recorded (probe.beatlog) → 10 pending",
        "--- recorded (probe.beatlog)",
        "+++ pending",
        "+0",
        "+1",
        "… 8 more diff lines: read specs/avoid-pole.dtc.pending",
    ]


def test_the_runs_of_rebuilt_robot_states_are_summed_up_a_line_each_up_to_twenty() -> None:
    first = (FieldDifference("speed", 0.04, 0.041), FieldDifference("heading", 1.5, -0.0))
    runs = [RebuiltRun(("heading", "speed"), 517, 4999, 4483, first)]
    runs += [RebuiltRun(("speed",), 6000 + n, 6000 + n, 1, first[:1]) for n in range(21)]
    diff = PendingDiff(SPEC, "recorded (probe.beatlog)", 0, 0, (), rebuilt_runs=tuple(runs))

    lines = plain_text(render_pending_diff(diff)).splitlines()

    assert lines[2:4] == [
        'robot state "heading", "speed" rebuilt otherwise in cycles 517–4999 (4483 cycles), '
        'first: "speed" 0.04 → 0.041, "heading" 1.5 → -0.0',
        'robot state "speed" rebuilt otherwise in cycles 6000–6000 (1 cycle), first: '
        '"speed" 0.04 → 0.041',
    ]
    assert lines[22:] == ["… 2 more runs: read specs/avoid-pole.dtc.pending"]
