"""In living replay, the replaying random source goes on where the behaviors ask for other
draws than were recorded, and notes each difference."""

from __future__ import annotations

from beatlog.model.context import Context
from beatlog.model.random import Draw
from beatlog.replaying.random import DrawDifference, ReplayRandom
from tests.factories import through_log


def living(recorded: list[Draw], names: tuple[str, ...] = ("wander", "escape")) -> ReplayRandom:
    """A living replay source for one cycle of ``recorded`` draws, behaviors ``names``."""
    source = ReplayRandom()
    context = Context(source)
    source.bind(context)
    context.cycle = 517
    source.expect_actors(names, names)
    source.live(b"a log")
    source.load(through_log(recorded))
    CONTEXTS[source] = context
    return source


CONTEXTS: dict[ReplayRandom, Context] = {}
"""The context each :func:`living` source is bound to."""


def drawing_as(source: ReplayRandom, actor: int) -> ReplayRandom:
    """``source``, with behavior ``actor`` drawing from it."""
    CONTEXTS[source].actor = actor
    return source


def test_living_replay_hands_back_the_recording_while_it_is_followed() -> None:
    source = living([Draw(0, "uniform", 1.2, (0.8, 1.6)), Draw(1, "randint", 3, (1, 6))])

    first = drawing_as(source, 0).uniform(0.8, 1.6)
    second = drawing_as(source, 1).randint(1, 6)

    assert (first, second) == (1.2, 3)
    assert source.settle() == []


def test_living_replay_re_maps_a_retuned_request_with_the_same_luck() -> None:
    source = living([Draw(0, "uniform", 1.25, (1.0, 2.0))])

    value = drawing_as(source, 0).uniform(2.0, 6.0)

    assert value == 3.0
    assert source.settle() == [DrawDifference("wander", "uniform(1.0, 2.0)", "uniform(2.0, 6.0)")]
    assert source.mismatch is None


def test_living_replay_gives_a_new_draw_fresh_luck_and_drops_an_unused_one() -> None:
    source = living([Draw(0, "uniform", 1.25, (1.0, 2.0))])

    value = drawing_as(source, 1).gauss(0.0, 1.0)
    again = living([Draw(0, "uniform", 1.25, (1.0, 2.0))])

    assert drawing_as(again, 1).gauss(0.0, 1.0) == value
    assert source.settle() == [
        DrawDifference("escape", None, "gauss(0.0, 1.0)"),
        DrawDifference("wander", "uniform(1.0, 2.0)", None),
    ]


def test_living_replay_matches_each_behaviors_draws_whatever_the_order() -> None:
    source = living([Draw(0, "uniform", 1.2, (0.8, 1.6)), Draw(1, "randint", 3, (1, 6))])

    second = drawing_as(source, 1).randint(1, 6)
    first = drawing_as(source, 0).uniform(0.8, 1.6)

    assert (first, second) == (1.2, 3)
    assert source.settle() == []


def test_living_replay_credits_a_draw_to_the_behavior_that_drew_it() -> None:
    source = living([Draw(0, "randint", 3, (1, 6))])

    drawing_as(source, 1).randint(1, 6)

    assert source.settle() == [
        DrawDifference("escape", None, "randint(1, 6)"),
        DrawDifference("wander", "randint(1, 6)", None),
    ]


def test_living_replay_prefers_a_recorded_draw_of_the_same_kind() -> None:
    source = living([Draw(0, "gauss", 0.5, (0.0, 1.0)), Draw(0, "uniform", 1.25, (1.0, 2.0))])

    value = drawing_as(source, 0).uniform(1.0, 2.0)

    assert value == 1.25
    assert source.settle() == [DrawDifference("wander", "gauss(0.0, 1.0)", None)]


def test_living_replay_maps_another_scalar_kind_by_quantile() -> None:
    source = living([Draw(0, "uniform", 5.0, (0.0, 10.0))])

    value = drawing_as(source, 0).randint(0, 9)

    assert value == 5
    assert source.settle() == [DrawDifference("wander", "uniform(0.0, 10.0)", "randint(0, 9)")]


def test_living_replay_never_maps_a_scalar_to_an_array() -> None:
    source = living([Draw(0, "uniform", 5.0, (0.0, 10.0))])

    array = drawing_as(source, 0).uniform_array(0.0, 10.0, 3)

    assert array.shape == (3,)
    assert source.settle() == [
        DrawDifference("wander", None, "uniform_array(0.0, 10.0, [3])"),
        DrawDifference("wander", "uniform(0.0, 10.0)", None),
    ]


def test_living_replay_of_a_behavior_gone_leaves_its_draws_unused() -> None:
    source = ReplayRandom()
    source.bind(Context(source))
    source.expect_actors(("wander", "gone"), ("wander",))
    source.live(b"a log")
    source.load(through_log([Draw(1, "uniform", 1.25, (1.0, 2.0))]))

    assert source.settle() == [DrawDifference("gone", "uniform(1.0, 2.0)", None)]
