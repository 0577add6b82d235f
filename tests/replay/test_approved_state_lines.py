"""A robot state's digest counts every bit of the state as a log encodes it, by XXH64."""

from __future__ import annotations

from beatlog.replay.approved_state_lines import state_digest
from tests.factories import encoded


def test_a_digest_counts_every_bit_of_the_state_as_a_log_encodes_it() -> None:
    assert state_digest(encoded({"a": 1, "b": 0.5})) == state_digest(encoded({"a": 1, "b": 0.5}))
    assert state_digest(encoded({"a": 0.0})) != state_digest(encoded({"a": -0.0}))
    assert state_digest(encoded({"a": 1})) != state_digest(encoded({"a": 1.0}))
    assert len(state_digest(b"")) == 8


def test_a_digest_is_xxh64_as_its_specification_gives_it() -> None:
    # the empty input's XXH64 (seed 0), from the xxHash specification's test vectors
    assert state_digest(b"") == bytes.fromhex("ef46db3751d8e999")
