"""The random source records every draw live and hands the same values back in replay."""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable

import msgspec
import numpy as np
import pytest

from beatlog.model.context import Context
from beatlog.model.random import (
    Draw,
    DrawKind,
    RandomSource,
    RecordingRandom,
    recorded_draw_problem,
)
from beatlog.replaying.random import RandomMismatch, ReplayRandom
from tests.factories import through_log


def draw_everything(source: RecordingRandom | ReplayRandom) -> list[object]:
    return [
        source.random(),
        source.uniform(2.0, 3.0),
        source.gauss(0.0, 1.0),
        source.randint(1, 6),
        source.choice(["a", "b", "c"]),
        source.uniform_array(0.0, 1.0, (2, 3)),
        source.normal_array(0.0, 1.0, 4),
        source.integers_array(0, 10, 5),
    ]


def test_recording_keeps_every_draw_with_its_kind_and_actor() -> None:
    source = RecordingRandom(seed=3)
    context = Context(source)
    source.bind(context)
    context.actor = 2
    draw_everything(source)
    draws = source.take()
    assert [d.kind for d in draws] == [kind.value for kind in DrawKind]
    assert {d.actor for d in draws} == {2}
    assert source.take() == []


def test_replay_returns_exactly_what_was_recorded() -> None:
    recorder = RecordingRandom(seed=11)
    live = draw_everything(recorder)
    player = ReplayRandom()
    player.load(through_log(recorder.take()))
    replayed = draw_everything(player)
    for want, got in zip(live, replayed, strict=True):
        if isinstance(want, np.ndarray):
            assert isinstance(got, np.ndarray)
            assert got.dtype == want.dtype
            assert got.shape == want.shape
            assert got.tobytes() == want.tobytes()
        else:
            assert got == want
            assert type(got) is type(want)
    assert player.mismatch is None
    assert len(player.drawn) == len(player.recorded)


def test_same_seed_same_draws() -> None:
    first, second = RecordingRandom(seed=5), RecordingRandom(seed=5)
    draw_everything(first)
    draw_everything(second)
    assert msgspec.msgpack.encode(first.take()) == msgspec.msgpack.encode(second.take())


def test_a_seed_draws_the_same_values_on_every_machine() -> None:
    """The source is counter-based and pure Python: these values are the same
    everywhere, whatever numpy is installed (or none)."""
    source = RecordingRandom(seed=5)
    values = [
        source.random(),
        source.uniform(2, 3),
        source.gauss(0, 1),
        source.randint(1, 6),
        source.choice("abc"),
    ]

    assert values == [0.719506700232845, 2.2511085072482238, -0.5674393290983566, 3, "a"]


@pytest.mark.parametrize(
    "draw",
    [
        lambda r: r.uniform_array(0.0, 1.0, 3),
        lambda r: r.normal_array(0.0, 1.0, 3),
        lambda r: r.integers_array(0, 9, 3),
    ],
)
def test_an_array_draw_without_numpy_says_what_to_install(
    draw: Callable[[RandomSource], object], monkeypatch: pytest.MonkeyPatch
) -> None:
    recorded = RecordingRandom(seed=1)
    draw(recorded)
    player = ReplayRandom()
    player.load(recorded.take())
    monkeypatch.setitem(sys.modules, "numpy", None)
    message = (
        "array draws (uniform_array, normal_array, integers_array) need numpy: "
        'pip install "beatlog[arrays]"'
    )

    for source in (RecordingRandom(seed=1), player):
        with pytest.raises(ModuleNotFoundError) as raised:
            draw(source)
        assert str(raised.value) == message
        assert raised.value.name == "numpy"


def test_drawing_more_than_recorded_is_a_mismatch() -> None:
    player = ReplayRandom()
    player.load([Draw(0, "uniform", 0.5)])
    player.uniform(0, 1)
    with pytest.raises(RandomMismatch) as caught:
        player.uniform(0, 1)
    assert (caught.value.problem, caught.value.overdrawn) == (
        "called uniform(0, 1) (#2) but only 1 were recorded",
        True,
    )


def test_drawing_another_kind_is_a_mismatch() -> None:
    player = ReplayRandom()
    player.load([Draw(0, "gauss", 0.5)])
    with pytest.raises(RandomMismatch, match=r"called uniform\(0, 1\) where gauss was recorded"):
        player.uniform(0, 1)
    assert player.mismatch is not None
    assert (player.mismatch.problem, player.mismatch.overdrawn) == (
        "called uniform(0, 1) where gauss was recorded",
        False,
    )
    assert player.drawn == [Draw(-1, "uniform", None, (0, 1))]


def test_drawing_another_kind_names_both_requests() -> None:
    player = ReplayRandom()
    player.load([Draw(0, "uniform", 0.5, (2.0, 5.0))])
    with pytest.raises(RandomMismatch) as caught:
        player.gauss(0.0, 0.4)
    assert caught.value.problem == "called gauss(0.0, 0.4) where uniform(2.0, 5.0) was recorded"


def test_a_swallowed_mismatch_is_still_remembered() -> None:
    player = ReplayRandom()
    player.load([])
    with contextlib.suppress(BaseException):  # a careless behavior swallowing everything
        player.random()
    assert player.mismatch is not None


def test_an_array_of_another_shape_is_a_mismatch() -> None:
    recorder = RecordingRandom(seed=1)
    recorder.uniform_array(0, 1, 3)
    player = ReplayRandom()
    player.load(through_log(recorder.take()))
    with pytest.raises(RandomMismatch, match=r"uniform_array\(0, 1, \[4\]\) where .*\[3\]"):
        player.uniform_array(0, 1, 4)


def test_a_format_1_array_of_another_shape_is_still_a_mismatch() -> None:
    recorder = RecordingRandom(seed=1)
    recorder.uniform_array(0, 1, 3)
    player = ReplayRandom()
    player.load([draw._replace(params=()) for draw in through_log(recorder.take())])
    with pytest.raises(RandomMismatch, match="shape"):
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
    with pytest.raises(RandomMismatch) as raised:
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
    assert player.mismatch is None
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
    with pytest.raises(RandomMismatch, match="out of range"):
        player.choice([1, 2])


def test_every_draw_a_recording_makes_reads_back_without_a_problem() -> None:
    recorder = RecordingRandom(seed=1)
    draw_everything(recorder)
    draws = through_log(recorder.take())

    assert [recorded_draw_problem(draw, 0) for draw in draws] == [None] * len(draws)
    format_1 = [draw._replace(params=()) for draw in draws]
    assert [recorded_draw_problem(draw, 0) for draw in format_1] == [None] * len(draws)
