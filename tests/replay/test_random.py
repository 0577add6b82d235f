"""The replaying random source hands back the recorded draws and refuses any other: more,
fewer, another kind or other parameters. Matching draws, it goes on where the behaviors
ask for other draws than were recorded, and notes each draw made otherwise."""

from __future__ import annotations

import contextlib
from collections.abc import Callable

import numpy as np
import pytest

from beatlog.model.context import Context
from beatlog.model.random import Draw, RandomSource, RecordingRandom
from beatlog.replay.draws import DrawMadeOtherwise
from beatlog.replay.random import RefusedDraw, ReplayRandom
from tests.factories import through_log


def matching(recorded: list[Draw], names: tuple[str, ...] = ("wander", "escape")) -> ReplayRandom:
    """A replay matching draws source for one cycle of ``recorded`` draws, behaviors ``names``."""
    source = ReplayRandom()
    context = Context(source)
    source.bind(context)
    context.cycle = 517
    source.expect_actors(names, names)
    source.match_draws(b"a log")
    source.load(through_log(recorded))
    CONTEXTS[source] = context
    return source


CONTEXTS: dict[ReplayRandom, Context] = {}
"""The context each :func:`matching` source is bound to."""


def drawing_as(source: ReplayRandom, actor: int) -> ReplayRandom:
    """``source``, with behavior ``actor`` drawing from it."""
    CONTEXTS[source].actor = actor
    return source


def test_matching_draws_hands_back_the_recording_while_it_is_followed() -> None:
    source = matching([Draw(0, "uniform", 1.2, (0.8, 1.6)), Draw(1, "randint", 3, (1, 6))])

    first = drawing_as(source, 0).uniform(0.8, 1.6)
    second = drawing_as(source, 1).randint(1, 6)

    assert (first, second) == (1.2, 3)
    assert source.settle() == []


def test_matching_draws_re_maps_a_retuned_request_at_the_same_quantile() -> None:
    source = matching([Draw(0, "uniform", 1.25, (1.0, 2.0))])

    value = drawing_as(source, 0).uniform(2.0, 6.0)

    assert value == 3.0
    assert source.settle() == [
        DrawMadeOtherwise("wander", "uniform(1.0, 2.0)", "uniform(2.0, 6.0)")
    ]
    assert source.refused is None


def test_matching_draws_gives_a_new_draw_a_fresh_quantile_and_drops_an_unused_one() -> None:
    source = matching([Draw(0, "uniform", 1.25, (1.0, 2.0))])

    value = drawing_as(source, 1).gauss(0.0, 1.0)
    again = matching([Draw(0, "uniform", 1.25, (1.0, 2.0))])

    assert drawing_as(again, 1).gauss(0.0, 1.0) == value
    assert source.settle() == [
        DrawMadeOtherwise("escape", None, "gauss(0.0, 1.0)"),
        DrawMadeOtherwise("wander", "uniform(1.0, 2.0)", None),
    ]


def test_matching_draws_matches_each_behaviors_draws_whatever_the_order() -> None:
    source = matching([Draw(0, "uniform", 1.2, (0.8, 1.6)), Draw(1, "randint", 3, (1, 6))])

    second = drawing_as(source, 1).randint(1, 6)
    first = drawing_as(source, 0).uniform(0.8, 1.6)

    assert (first, second) == (1.2, 3)
    assert source.settle() == []


def test_matching_draws_credits_a_draw_to_the_behavior_that_drew_it() -> None:
    source = matching([Draw(0, "randint", 3, (1, 6))])

    drawing_as(source, 1).randint(1, 6)

    assert source.settle() == [
        DrawMadeOtherwise("escape", None, "randint(1, 6)"),
        DrawMadeOtherwise("wander", "randint(1, 6)", None),
    ]


def test_matching_draws_prefers_a_recorded_draw_of_the_same_kind() -> None:
    source = matching([Draw(0, "gauss", 0.5, (0.0, 1.0)), Draw(0, "uniform", 1.25, (1.0, 2.0))])

    value = drawing_as(source, 0).uniform(1.0, 2.0)

    assert value == 1.25
    assert source.settle() == [DrawMadeOtherwise("wander", "gauss(0.0, 1.0)", None)]


def test_matching_draws_maps_another_scalar_kind_by_quantile() -> None:
    source = matching([Draw(0, "uniform", 5.0, (0.0, 10.0))])

    value = drawing_as(source, 0).randint(0, 9)

    assert value == 5
    assert source.settle() == [DrawMadeOtherwise("wander", "uniform(0.0, 10.0)", "randint(0, 9)")]


def test_matching_draws_never_maps_a_scalar_to_an_array() -> None:
    source = matching([Draw(0, "uniform", 5.0, (0.0, 10.0))])

    array = drawing_as(source, 0).uniform_array(0.0, 10.0, 3)

    assert array.shape == (3,)
    assert source.settle() == [
        DrawMadeOtherwise("wander", None, "uniform_array(0.0, 10.0, [3])"),
        DrawMadeOtherwise("wander", "uniform(0.0, 10.0)", None),
    ]


def test_matching_draws_of_a_behavior_gone_leaves_its_draws_unused() -> None:
    source = ReplayRandom()
    source.bind(Context(source))
    source.expect_actors(("wander", "gone"), ("wander",))
    source.match_draws(b"a log")
    source.load(through_log([Draw(1, "uniform", 1.25, (1.0, 2.0))]))

    assert source.settle() == [DrawMadeOtherwise("gone", "uniform(1.0, 2.0)", None)]


def test_drawing_more_than_recorded_is_a_mismatch() -> None:
    player = ReplayRandom()
    player.load([Draw(0, "uniform", 0.5)])
    player.uniform(0, 1)
    with pytest.raises(RefusedDraw) as caught:
        player.uniform(0, 1)
    assert (caught.value.problem, caught.value.overdrawn) == (
        "called uniform(0, 1) (#2) but only 1 were recorded",
        True,
    )


def test_drawing_another_kind_is_a_mismatch() -> None:
    player = ReplayRandom()
    player.load([Draw(0, "gauss", 0.5)])
    with pytest.raises(RefusedDraw, match=r"called uniform\(0, 1\) where gauss was recorded"):
        player.uniform(0, 1)
    assert player.refused is not None
    assert (player.refused.problem, player.refused.overdrawn) == (
        "called uniform(0, 1) where gauss was recorded",
        False,
    )
    assert player.drawn == [Draw(-1, "uniform", None, (0, 1))]


def test_drawing_another_kind_names_both_requests() -> None:
    player = ReplayRandom()
    player.load([Draw(0, "uniform", 0.5, (2.0, 5.0))])
    with pytest.raises(RefusedDraw) as caught:
        player.gauss(0.0, 0.4)
    assert caught.value.problem == "called gauss(0.0, 0.4) where uniform(2.0, 5.0) was recorded"


def test_a_swallowed_mismatch_is_still_remembered() -> None:
    player = ReplayRandom()
    player.load([])
    with contextlib.suppress(BaseException):  # a careless behavior swallowing everything
        player.random()
    assert player.refused is not None


def test_an_array_of_another_shape_is_a_mismatch() -> None:
    recorder = RecordingRandom(seed=1)
    recorder.uniform_array(0, 1, 3)
    player = ReplayRandom()
    player.load(through_log(recorder.take()))
    with pytest.raises(RefusedDraw, match=r"uniform_array\(0, 1, \[4\]\) where .*\[3\]"):
        player.uniform_array(0, 1, 4)


def test_a_format_1_array_of_another_shape_is_still_a_mismatch() -> None:
    recorder = RecordingRandom(seed=1)
    recorder.uniform_array(0, 1, 3)
    player = ReplayRandom()
    player.load([draw._replace(params=()) for draw in through_log(recorder.take())])
    with pytest.raises(RefusedDraw, match="shape"):
        player.uniform_array(0, 1, 4)


@pytest.mark.parametrize(
    ("recorded", "replayed", "message"),
    [
        (
            lambda r: r.uniform(2.0, 5.0),
            lambda r: r.uniform(2.5, 5.0),
            "called uniform(2.5, 5.0) where uniform(2.0, 5.0) was recorded",
        ),
        (
            lambda r: r.gauss(0.0, 0.4),
            lambda r: r.gauss(0.5, 0.4),
            "called gauss(0.5, 0.4) where gauss(0.0, 0.4) was recorded",
        ),
        (
            lambda r: r.randint(1, 6),
            lambda r: r.randint(1, 7),
            "called randint(1, 7) where randint(1, 6) was recorded",
        ),
        (
            lambda r: r.choice("abc"),
            lambda r: r.choice("abcd"),
            "called choice(4) where choice(3) was recorded",
        ),
        (
            lambda r: r.normal_array(0.0, 1.0, (2, 2)),
            lambda r: r.normal_array(0.0, 2.0, (2, 2)),
            "called normal_array(0.0, 2.0, [2, 2]) where normal_array(0.0, 1.0, [2, 2])",
        ),
        (
            lambda r: r.gauss(float("nan"), 1.0),
            lambda r: r.gauss(0.0, 1.0),
            "called gauss(0.0, 1.0) where gauss(nan, 1.0) was recorded",
        ),
        (
            lambda r: r.uniform(2.0, 5.0),
            lambda r: r.uniform(2.0000000000000004, 5.0),
            "called uniform(2.0000000000000004, 5.0) where uniform(2.0, 5.0) was recorded",
        ),
        (
            lambda r: r.integers_array(0, 10, (2, 2)),
            lambda r: r.integers_array(0, 10, (2, 2, 1)),
            "called integers_array(0, 10, [2, 2, 1]) where integers_array(0, 10, [2, 2])",
        ),
        (
            lambda r: r.integers(0, 10),
            lambda r: r.integers(0, 11),
            "called randint(0, 10) where randint(0, 9) was recorded",
        ),
        (
            lambda r: r.normal(30.0, 2.5),
            lambda r: r.normal(30.0, 3.0),
            "called gauss(30.0, 3.0) where gauss(30.0, 2.5) was recorded",
        ),
        (
            lambda r: r.uniform(0.0, 1.0, size=3),
            lambda r: r.uniform(0.0, 1.0, size=4),
            "called uniform_array(0.0, 1.0, [4]) where uniform_array(0.0, 1.0, [3])",
        ),
        (
            lambda r: r.choice(4, size=2, replace=False),
            lambda r: r.choice(5, size=2, replace=False),
            "called uniform_array(0.0, 1.0, [5]) where uniform_array(0.0, 1.0, [4])",
        ),
    ],
)
def test_a_draw_asked_with_other_parameters_is_a_mismatch(
    recorded: Callable[[RandomSource], object],
    replayed: Callable[[RandomSource], object],
    message: str,
) -> None:
    recorder = RecordingRandom(seed=1)
    recorded(recorder)
    player = ReplayRandom()
    player.load(through_log(recorder.take()))
    with pytest.raises(RefusedDraw) as raised:
        replayed(player)
    assert message in raised.value.problem


@pytest.mark.parametrize(
    ("recorded", "replayed"),
    [
        (lambda r: r.gauss(-0.0, 1.0), lambda r: r.gauss(-0.0, 1.0)),
        (lambda r: r.gauss(float("nan"), 1.0), lambda r: r.gauss(float("nan"), 1.0)),
        (lambda r: r.uniform(1.5, 3), lambda r: r.uniform(np.float64(1.5), np.int64(3))),
        (lambda r: r.randint(1, 6), lambda r: r.randint(np.int64(1), 6)),
        (lambda r: r.uniform_array(0.0, 1.0, (2, 3)), lambda r: r.uniform_array(0.0, 1.0, (2, 3))),
        # the same numbers written otherwise: 1 == 1.0 == True, -0.0 == 0.0
        (lambda r: r.uniform(1, 2), lambda r: r.uniform(1.0, 2)),
        (lambda r: r.uniform(1.0, 2.0), lambda r: r.uniform(1, 2.0)),
        (lambda r: r.randint(1, 6), lambda r: r.randint(True, 6)),
        (lambda r: r.gauss(-0.0, 1.0), lambda r: r.gauss(0.0, 1.0)),
        (lambda r: r.integers_array(0, 10, (2, 2)), lambda r: r.integers_array(0, 10, (2.0, 2))),
    ],
)
def test_the_same_numbers_asked_for_replay(
    recorded: Callable[[RandomSource], object],
    replayed: Callable[[RandomSource], object],
) -> None:
    """Numbers compare by value, exactly, however written: numpy scalars, ints for
    floats; a NaN is the NaN recorded. They draw the same."""
    recorder = RecordingRandom(seed=1)
    recorded(recorder)
    player = ReplayRandom()
    player.load(through_log(recorder.take()))
    replayed(player)
    assert player.refused is None
    assert len(player.drawn) == 1


def test_the_same_parameters_replay_the_recorded_value() -> None:
    recorder = RecordingRandom(seed=1)
    value = recorder.uniform(2.0, 5.0)
    player = ReplayRandom()
    player.load(through_log(recorder.take()))
    assert player.uniform(2.0, 5.0) == value


def test_a_format_1_draw_has_no_parameters_and_is_checked_for_kind_only() -> None:
    player = ReplayRandom()
    player.load([Draw(0, "uniform", 0.25)])
    assert player.uniform(2.5, 5.0) == 0.25


def test_a_recorded_choice_must_fit_the_sequence() -> None:
    player = ReplayRandom()
    player.load([Draw(0, "choice", 5)])
    with pytest.raises(RefusedDraw, match="out of range"):
        player.choice([1, 2])
