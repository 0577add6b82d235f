"""What an intended change loses and gains: lost state changes are named per behavior,
with their cycles, never folded into a count; a change that only moves is no loss."""

from __future__ import annotations

from beatlog.analysis.shift import Loss, LossKind, shift
from beatlog.replay.baseline import ABSENT, TracedOutput, TracedStateChange
from beatlog.replay.draws import ApprovedDraws
from beatlog.replay.verdict import StateChange

ESCAPES = [
    TracedStateChange(291, 0, StateChange("escape", "idle", "backing")),
    TracedStateChange(325, 0, StateChange("escape", "backing", "turning")),
    TracedStateChange(367, 0, StateChange("escape", "turning", "idle")),
]
WANDERS = [
    TracedStateChange(10, 0, StateChange("wander", "left", "right")),
    TracedStateChange(50, 0, StateChange("wander", "right", "left")),
]


def test_state_changes_that_no_longer_happen_are_losses_of_their_behavior() -> None:
    moved = [c._replace(cycle=c.cycle + 1) for c in WANDERS]
    turned = [TracedOutput(291, 0, "turn", 0.5), TracedOutput(400, 0, "turn", ABSENT)]
    unused = ApprovedDraws("escape", "choice(2)", None, (325,))

    weighed = shift(
        ([*WANDERS, *ESCAPES], [TracedOutput(0, 0, "speed", 0.2), *turned]),
        (moved, [TracedOutput(0, 0, "speed", 0.2)]),
        cycles=583,
        open_loop=11,
        draws_after=[unused],
    )

    assert weighed.losses == (
        Loss(LossKind.STATE_CHANGES, "escape", (291, 325, 367), silent=True),
        Loss(LossKind.OUTPUT, "turn", (291,)),
        Loss(LossKind.DRAWS, "escape", (325,), request="choice(2)"),
    )
    assert (weighed.lost, weighed.gained, weighed.moved) == (3, 0, 2)
    assert weighed.closed_loop == 11


def test_a_behavior_that_still_acts_is_not_silent_and_new_changes_are_no_loss() -> None:
    fewer = [*WANDERS, ESCAPES[0], ESCAPES[2]._replace(cycle=300)]
    extra = TracedStateChange(500, 0, StateChange("escape", "idle", "backing"))

    weighed = shift(([*WANDERS, *ESCAPES], []), ([*fewer, extra], []), cycles=583, open_loop=None)

    assert weighed.losses == (Loss(LossKind.STATE_CHANGES, "escape", (325,)),)
    assert (weighed.lost, weighed.gained, weighed.moved) == (1, 1, 1)
    assert weighed.closed_loop == 583


def test_draws_left_unused_already_approved_are_no_new_loss() -> None:
    unused = ApprovedDraws("escape", "choice(2)", None, (325,))

    weighed = shift(
        (ESCAPES, []), (ESCAPES, []), cycles=400, open_loop=None,
        draws_before=[unused], draws_after=[unused],
    )  # fmt: skip

    assert weighed.losses == ()


def test_a_state_change_still_in_its_cycle_is_matched_there_before_any_is_moved() -> None:
    backing = StateChange("escape", "idle", "backing")
    twice = [TracedStateChange(100, 0, backing), TracedStateChange(500, 0, backing)]

    weighed = shift((twice, []), (twice[1:], []), cycles=600, open_loop=100)

    assert weighed.losses == (Loss(LossKind.STATE_CHANGES, "escape", (100,)),)
    assert (weighed.lost, weighed.gained, weighed.moved) == (1, 0, 0)
