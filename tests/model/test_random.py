"""The random source records every draw live and hands the same values back in replay."""

from __future__ import annotations

import sys
from collections.abc import Callable

import msgspec
import numpy as np
import pytest

from beatlog.model.context import Context
from beatlog.model.random import (
    DrawKind,
    RandomSource,
    RecordingRandom,
    recorded_draw_problem,
)
from beatlog.replay.random import ReplayRandom
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
    assert player.refused is None
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


def test_every_draw_a_recording_makes_reads_back_without_a_problem() -> None:
    recorder = RecordingRandom(seed=1)
    draw_everything(recorder)
    draws = through_log(recorder.take())

    assert [recorded_draw_problem(draw, 0) for draw in draws] == [None] * len(draws)
    format_1 = [draw._replace(params=()) for draw in draws]
    assert [recorded_draw_problem(draw, 0) for draw in format_1] == [None] * len(draws)
