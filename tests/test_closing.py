"""Closing: a with block closes the object, also when the block raises."""

from __future__ import annotations

import pytest

from beatlog.closing import Closing


class Held(Closing):
    def __init__(self) -> None:
        self.closed = 0

    def close(self) -> None:
        self.closed += 1


def test_the_block_gets_the_object_and_closes_it() -> None:
    with Held() as held:
        assert held.closed == 0
    assert held.closed == 1


def test_a_block_that_raises_still_closes_and_the_error_goes_on() -> None:
    held = Held()
    with pytest.raises(ValueError, match="boom"), held:
        raise ValueError("boom")
    assert held.closed == 1
