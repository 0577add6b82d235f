"""Draws at set-up: a factory that takes ``random`` is handed the random source."""

from __future__ import annotations

import functools

from beatlog.model.behavior import PriorityArbiter, System
from beatlog.model.random import RecordingRandom
from beatlog.model.setup import build_system, takes_random
from beatlog.model.source import RandomSource
from tests.conftest import Probe, probe_system


def by_keyword(*, random: RandomSource) -> System:
    return PriorityArbiter([], robot_state=Probe)


def positionally(random: RandomSource, gain: float = 1.0) -> System:
    return PriorityArbiter([], robot_state=Probe)


def only_positionally(random: RandomSource, /) -> System:
    return PriorityArbiter([], robot_state=Probe)


def test_a_factory_takes_random_when_it_names_the_parameter_and_passing_it_by_name_works() -> None:
    assert takes_random(by_keyword)
    assert takes_random(positionally)
    assert takes_random(functools.partial(positionally, gain=2.0))
    assert not takes_random(only_positionally)
    assert not takes_random(probe_system)
    assert not takes_random(print)


def test_a_factory_that_takes_random_draws_from_the_source_it_is_handed() -> None:
    source = RecordingRandom(seed=1)

    def drawing(random: RandomSource) -> System:
        random.uniform(0.0, 1.0)
        return probe_system()

    build_system(drawing, source)
    build_system(probe_system, source)

    assert [draw.kind for draw in source.take()] == ["uniform"]
