"""The priority arbiter: every behavior steps, the highest one asking for control wins."""

from __future__ import annotations

import pytest

from beatlog.model.behavior import Behavior, BehaviorState, PriorityArbiter, System
from beatlog.model.context import Context, Outputs
from beatlog.model.random import RecordingRandom
from beatlog.model.state import RobotState


class Level(RobotState, kw_only=True):
    level: int = 0


class Wants:
    """Asks for control when the level reaches its own threshold; remembers its actor."""

    def __init__(self, name: str, threshold: int) -> None:
        self.name = name
        self.state: BehaviorState = "quiet"
        self.threshold = threshold
        self.steps = 0
        self.actor = -1

    def step(self, rs: Level, ctx: Context) -> Outputs | None:
        self.steps += 1
        self.actor = ctx.actor
        wants = rs.level >= self.threshold
        self.state = "active" if wants else "quiet"
        return {"who": self.name} if wants else None


def make() -> tuple[PriorityArbiter[Level], Context, list[Wants]]:
    behaviors = [Wants("high", 2), Wants("low", 1)]
    arbiter = PriorityArbiter(behaviors, robot_state=Level)
    return arbiter, Context(RecordingRandom(seed=0)), behaviors


@pytest.mark.parametrize(
    ("level", "winner", "outputs"),
    [(0, "idle", {}), (1, "low", {"who": "low"}), (2, "high", {"who": "high"})],
)
def test_highest_priority_asking_behavior_wins(
    level: int, winner: str, outputs: dict[str, str]
) -> None:
    arbiter, context, behaviors = make()
    arbiter.update(Level(level=level), context)
    assert arbiter.state == winner
    assert context.outputs == outputs
    assert [b.steps for b in behaviors] == [1, 1]


def test_catalogue_lists_arbiter_then_behaviors_in_priority_order() -> None:
    arbiter, context, behaviors = make()
    assert list(arbiter.behaviors) == ["arbiter", "high", "low"]
    arbiter.update(Level(), context)
    assert [b.actor for b in behaviors] == [1, 2]
    assert isinstance(arbiter, System)
    assert all(isinstance(b, Behavior) for b in arbiter.behaviors.values())


def test_duplicate_names_are_refused() -> None:
    with pytest.raises(ValueError, match="two behaviors are named 'same'"):
        PriorityArbiter([Wants("same", 1), Wants("same", 2)], robot_state=Level)
