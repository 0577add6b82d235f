"""Code written for numpy's ``Generator`` takes a behavior's random source unchanged:
numpy's calls, with numpy's signatures and types, recorded and replayed like the
others."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from beatlog.model.random import (
    RandomSource,
    RecordingRandom,
    recorded_draw_problem,
)
from beatlog.replay.random import ReplayRandom
from tests.factories import through_log


def driving_code(rng: Any) -> list[Any]:
    """Draws as a simulator's numpy code makes them, from a ``Generator`` it was given."""
    return [
        rng.uniform(low=0.8, high=1.6),
        rng.uniform(low=0.0, high=2.0, size=3),
        rng.uniform(2, 5),
        rng.normal(loc=30.0, scale=2.5),
        rng.normal(size=(2, 2)),
        rng.integers(0, 3),
        rng.integers(4),
        rng.integers(1, 6, endpoint=True),
        rng.integers(0, 10, size=5),
        rng.integers(np.int64(2), np.int64(9), size=(2,), dtype=np.int32),
        rng.choice(5),
        rng.choice([0.5, 1.0, 1.5], p=[0.2, 0.3, 0.5]),
        rng.choice(4, size=3),
        rng.choice(["keep", "left", "right"], size=2, p=np.array([0.5, 0.25, 0.25])),
        rng.choice(6, size=4, replace=False),
        rng.choice(4, size=2, replace=False, p=[0.0, 0.5, 0.25, 0.25]),
        rng.random(),
        rng.random(size=2),
        rng.random(3),
    ]


def _kind_of(value: Any) -> Any:
    """What numpy code may rely on in a draw: its type, and an array's dtype and shape."""
    if isinstance(value, np.ndarray):
        return (np.ndarray, value.dtype, value.shape)
    return type(value)


def test_numpy_code_gets_what_a_numpy_generator_gives_it() -> None:
    wanted = [_kind_of(value) for value in driving_code(np.random.default_rng(1))]

    got = [_kind_of(value) for value in driving_code(RecordingRandom(seed=1))]

    # a list's element is handed back as it is (random.Random's choice), where numpy
    # gives its own float of the same value
    assert wanted[11] is np.float64
    assert got[11] is float
    assert got[:11] + got[12:] == wanted[:11] + wanted[12:]


def test_numpy_code_replays_the_values_it_drew() -> None:
    recorder = RecordingRandom(seed=4)
    live = driving_code(recorder)
    draws = through_log(recorder.take())
    player = ReplayRandom()
    player.load(draws)

    replayed = driving_code(player)

    assert [recorded_draw_problem(draw, 0) for draw in draws] == [None] * len(draws)
    assert player.refused is None
    assert len(player.drawn) == len(draws)
    for want, got in zip(live, replayed, strict=True):
        assert _kind_of(got) == _kind_of(want)
        assert np.array_equal(got, want)


def test_numpy_calls_are_recorded_as_the_requests_they_are() -> None:
    recorder = RecordingRandom(seed=1)
    recorder.integers(0, 10)
    recorder.integers(1, 6, endpoint=True)
    recorder.normal(1.0, 0.5)
    recorder.uniform(low=1.0, high=2.0, size=(2, 3))
    recorder.random(size=2)
    recorder.choice(["a", "b"], p=[0.5, 0.5])

    assert [draw.call() for draw in recorder.take()] == [
        "randint(0, 9)",
        "randint(1, 6)",
        "gauss(1.0, 0.5)",
        "uniform_array(1.0, 2.0, [2, 3])",
        "uniform_array(0.0, 1.0, [2])",
        "random()",
    ]


def test_random_without_size_is_still_random_randoms() -> None:
    recorder = RecordingRandom(seed=5)

    assert recorder.random() == 0.719506700232845
    assert [draw.call() for draw in recorder.take()] == ["random()"]


@pytest.mark.parametrize(
    "draw",
    [
        lambda r: r.choice(3, size=4, replace=False),
        lambda r: r.choice(3, size=2, replace=False, p=[0.0, 0.0, 1.0]),
    ],
)
def test_more_picks_than_elements_without_repeats_is_refused(
    draw: Callable[[RandomSource], object],
) -> None:
    with pytest.raises(ValueError, match="without repeats"):
        draw(RecordingRandom(seed=1))


@pytest.mark.parametrize(
    ("draw", "problem"),
    [
        (lambda r: r.choice(3, p=[0.5, 0.5]), "2 probabilities for 3 elements"),
        (lambda r: r.choice(2, p=[0.5, 0.6]), "add up to 1"),
        (lambda r: r.choice(2, p=[1.5, -0.5]), "non-negative"),
        (lambda r: r.integers(5, 5), r"no int in \[5, 5\)"),
        (lambda r: r.uniform(np.zeros(2), 1.0, size=2), "a number for each bound"),
    ],
)
def test_numpy_calls_numpy_refuses_are_refused(
    draw: Callable[[RandomSource], object], problem: str
) -> None:
    recorder = RecordingRandom(seed=1)

    with pytest.raises((ValueError, TypeError), match=problem):
        draw(recorder)
    assert recorder.take() == []


def test_a_weighted_choice_never_picks_a_weight_of_zero() -> None:
    recorder = RecordingRandom(seed=2)

    picks = {recorder.choice("abc", p=[0.5, 0.0, 0.5]) for _ in range(200)}
    arrays = recorder.choice(3, size=200, p=[0.0, 1.0, 0.0])

    assert picks == {"a", "c"}
    assert set(arrays.tolist()) == {1}
