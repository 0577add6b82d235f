"""The re-baselining workflow in words: one line per pending file touched, saying how to
go on, the same for the terminal and the pytest summary."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.analysis.shift import Loss, LossKind, Shift
from beatlog.replay.approved_state_lines import ApprovedRun
from beatlog.replay.baseline import Baseline, TracedOutput
from beatlog.replay.draws import ApprovedDraws
from beatlog.report.baselines import (
    loss_text,
    render_orphans,
    render_pending_diff,
    render_updates,
)
from beatlog.report.console import plain_text
from beatlog.suite.maintenance import PendingDiff, PendingUpdate, UpdateAction
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
CLOSED = Shift((), 0, 0, 0, 300, None)
"""What a change that loses nothing and stays closed loop does."""
ESCAPE_LOST = (
    Loss(LossKind.STATE_CHANGES, "escape", (291, 325, 367), silent=True),
    Loss(LossKind.OUTPUT, "turn", (12, 40)),
    Loss(LossKind.DRAWS, "escape", (325,), request="choice(2)"),
)
"""The losses of a dog that no longer escapes."""

LINES = {
    UpdateAction.WRITTEN: "pending specs/avoid-pole.dtc.pending (0 state changes lost, 0 new, "
    "0 moved, 5 output changes): review with beatlog review specs/avoid-pole.dtc.toml, accept with "
    "beatlog approve specs/avoid-pole.dtc.toml",
    UpdateAction.WITHHELD: "CI is set: no pending baselines written",
    UpdateAction.REFUSED: "not updated avoid-pole: re-record the session",
    UpdateAction.REMOVED: "removed stale specs/avoid-pole.dtc.pending: avoid-pole passes",
}


def outputs(count: int) -> tuple[TracedOutput, ...]:
    """``count`` changes of an output field."""
    return tuple(TracedOutput(cycle, cycle, "turn", cycle) for cycle in range(count))


@pytest.mark.parametrize("action", list(UpdateAction))
def test_each_update_action_is_one_line(action: UpdateAction) -> None:
    reason = "re-record the session" if action is UpdateAction.REFUSED else None
    update = PendingUpdate(SPEC, action, PENDING, CLOSED, Baseline((), outputs(5)), reason)

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
    diff = PendingDiff(SPEC, "recorded (probe.beatlog)", 0, 10, lines, CLOSED)

    text = plain_text(render_pending_diff(diff, max_lines=4))

    assert text.splitlines()[1:] == [
        "0 state and output changes recorded (probe.beatlog) → 10 pending: 0 state changes "
        "lost, 0 new, 0 moved",
        "closed loop for 300 of 300 cycles (100 %)",
        "--- recorded (probe.beatlog)",
        "+++ pending",
        "+0",
        "+1",
        "… 8 more diff lines: read specs/avoid-pole.dtc.pending",
    ]


def test_the_runs_of_rebuilt_robot_states_are_summed_up_a_line_each_up_to_twenty() -> None:
    runs = [
        ApprovedRun(517, 0, 4999, 4483, ("heading", "speed"), {"speed": 0.041, "heading": -0.0})
    ]
    runs += [ApprovedRun(6000 + n, 0, 6000 + n, 1, ("speed",), {"speed": 0.041}) for n in range(21)]
    recorded = {run.cycle: {"speed": 0.04, "heading": 1.5} for run in runs}
    diff = PendingDiff(
        SPEC,
        "recorded (probe.beatlog)",
        0,
        0,
        (),
        CLOSED,
        rebuilt_runs=tuple(runs),
        recorded=recorded,
    )

    lines = plain_text(render_pending_diff(diff)).splitlines()

    assert lines[3:5] == [
        'robot state "heading", "speed" rebuilt otherwise in cycles 517–4999 (4483 cycles), '
        'first: "speed" 0.04 → 0.041, "heading" 1.5 → -0.0',
        'robot state "speed" rebuilt otherwise in cycles 6000–6000 (1 cycle), first: '
        '"speed" 0.04 → 0.041',
    ]
    assert lines[23:] == ["… 2 more runs: read specs/avoid-pole.dtc.pending"]


def test_each_loss_is_said_in_its_own_words() -> None:
    many = Loss(LossKind.STATE_CHANGES, "near", tuple(range(0, 120, 10)))

    assert [loss_text(loss) for loss in (*ESCAPE_LOST, many)] == [
        '"escape": 3 state changes no longer happen (cycles 291, 325, 367); it never changes '
        "state in this DTC any more",
        'output "turn": never output any more (output today from cycle 12)',
        'draws "escape": 1 recorded draw of choice(2) no longer made (cycle 325)',
        '"near": 12 state changes no longer happen (cycles 0, 10, 20, 30, 40, 50, 60, 70, 80, '
        "90 and 2 more)",
    ]


def test_a_pending_update_counts_and_names_what_it_loses_and_how_much_stays_closed_loop() -> None:
    lost = Shift(ESCAPE_LOST, 3, 0, 1, 1164, 291)
    baseline = Baseline((), outputs(4), open_loop=(291, 8_760_000_000))
    update = PendingUpdate(SPEC, UpdateAction.WRITTEN, PENDING, lost, baseline)

    lines = [line.plain for line in render_updates([update])]

    assert lines[0].startswith(
        "pending specs/avoid-pole.dtc.pending (3 state changes lost, 0 new, 1 moved, 4 output "
        "changes, open loop since cycle 291 (8.760 s), closed loop for 291 of 1164 cycles "
        "(25 %)): review with"
    )
    assert lines[1:] == [f"  lost in avoid-pole: {loss_text(loss)}" for loss in ESCAPE_LOST]


def test_the_review_names_each_loss_and_the_draws_it_does_not_name() -> None:
    lost = Shift(ESCAPE_LOST, 3, 0, 0, 1164, 291)
    draws = (
        ApprovedDraws("escape", "choice(2)", None, (325,)),
        ApprovedDraws("wander", "uniform(0.8, 1.6)", "uniform(0.7, 1.5)", (12,)),
    )
    diff = PendingDiff(
        SPEC,
        "recorded (probe.beatlog)",
        0,
        0,
        (),
        lost,
        draws=draws,
        open_loop=(291, 8_760_000_000),
    )

    lines = plain_text(render_pending_diff(diff)).splitlines()

    assert lines[1:7] == [
        "0 state and output changes recorded (probe.beatlog) → 0 pending: 3 state changes "
        "lost, 0 new, 0 moved",
        "open loop since cycle 291 (8.760 s): closed loop for 291 of 1164 cycles (25 %)",
        *(f"lost: {loss_text(loss)}" for loss in ESCAPE_LOST),
        "draws wander: uniform(0.8, 1.6) -> uniform(0.7, 1.5), 1 draw re-mapped",
    ]
