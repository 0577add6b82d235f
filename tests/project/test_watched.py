"""What a leak watch watches: numpy's global generator seen to move as its state does."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np
import pytest

from beatlog.project.watched import GlobalNumpyGenerator


@pytest.fixture(autouse=True)
def numpy_state_kept() -> Iterator[None]:
    saved = np.random.get_state()
    yield
    np.random.set_state(saved)


def stands() -> tuple[int, str]:
    """Where numpy's global generator stands, read the slow way: its whole state."""
    bit_generator = np.random.mtrand._rand._bit_generator
    return id(bit_generator), repr(bit_generator.state)


def test_numpys_global_generator_moves_exactly_when_its_whole_state_changes() -> None:
    steps: list[Callable[[], object]] = [
        lambda: None,
        np.random.rand,
        lambda: np.random.rand(311),  # with the draw before, the key's 624 words
        lambda: np.random.randint(0, 2**31, size=2),  # the key regenerated
        lambda: np.random.rand(624),  # a whole key's length
        lambda: np.random.seed(3),
        lambda: np.random.seed(3),  # seeded to where it stands
        lambda: np.random.set_state(np.random.get_state()),
        lambda: np.random.shuffle([1, 2, 3]),
    ]
    watch = GlobalNumpyGenerator()
    before = stands()
    seen = []
    for step in steps:
        step()
        now = stands()
        seen.append((watch.moved(), now != before))
        before = now

    assert [moved for moved, _ in seen] == [changed for _, changed in seen]
    assert [moved for moved, _ in seen] == [False, True, True, True, True, True, False, False, True]
