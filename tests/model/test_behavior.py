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


class Proposes:
    """Proposes its outputs once the level reaches its threshold."""

    def __init__(self, name: str, threshold: int, outputs: Outputs) -> None:
        self.name = name
        self.state: BehaviorState = "quiet"
        self.threshold = threshold
        self.outputs = outputs

    def step(self, rs: Level, ctx: Context) -> Outputs | None:
        return self.outputs if rs.level >= self.threshold else None


def driver(*, per_output: bool) -> PriorityArbiter[Level]:
    """A driving stack: an emergency brake over car following (both longitudinal),
    and lane keeping (lateral) below them."""
    behaviors = [
        Proposes("brake", 3, {"acceleration": -5.0}),
        Proposes("follow", 1, {"acceleration": 1.0}),
        Proposes("keep_lane", 0, {"steering": 0.1}),
    ]
    return PriorityArbiter(behaviors, robot_state=Level, per_output=per_output)


@pytest.mark.parametrize(
    ("level", "winners", "outputs"),
    [
        (0, "steering: keep_lane", {"steering": 0.1}),
        (1, "acceleration: follow, steering: keep_lane", {"acceleration": 1.0, "steering": 0.1}),
        (3, "acceleration: brake, steering: keep_lane", {"acceleration": -5.0, "steering": 0.1}),
    ],
)
def test_per_output_each_output_goes_to_its_highest_proposer(
    level: int, winners: str, outputs: Outputs
) -> None:
    arbiter = driver(per_output=True)
    context = Context(RecordingRandom(seed=0))

    arbiter.update(Level(level=level), context)

    assert arbiter.state == winners
    assert context.outputs == outputs
    assert context.actor == 0


def test_per_output_is_idle_while_nothing_is_proposed() -> None:
    arbiter = PriorityArbiter(
        [Proposes("follow", 1, {"acceleration": 1.0})], robot_state=Level, per_output=True
    )
    context = Context(RecordingRandom(seed=0))

    arbiter.update(Level(level=0), context)

    assert (arbiter.state, context.outputs) == ("idle", {})


def test_one_winner_takes_every_output_by_default() -> None:
    arbiter = driver(per_output=False)
    context = Context(RecordingRandom(seed=0))

    arbiter.update(Level(level=1), context)

    assert (arbiter.state, context.outputs) == ("follow", {"acceleration": 1.0})


@pytest.mark.parametrize("per_output", [False, True])
@pytest.mark.parametrize("bare", [1.0, 0.0, "left"])
def test_a_step_that_returns_a_bare_value_is_named_with_what_it_should_return(
    bare: object, per_output: bool
) -> None:
    returns_bare = Proposes("turn", 0, {})
    returns_bare.outputs = bare  # type: ignore[assignment]  # the slip under test
    arbiter = PriorityArbiter([returns_bare], robot_state=Level, per_output=per_output)

    with pytest.raises(TypeError) as raised:
        arbiter.update(Level(), Context(RecordingRandom(seed=0)))

    assert str(raised.value) == (
        f"behavior 'turn': step returned {bare!r}; it returns the outputs it asks for, "
        "a dict such as {'turn': 1.0}, or None"
    )
