"""A robot state's digest: every bit of the state as a log encodes it, by the
digest of the baseline's format."""

from __future__ import annotations

from beatlog.replaying.state_digests import BLAKE2B, state_digest
from tests.factories import encoded


def test_a_digest_counts_every_bit_of_the_state_as_a_log_encodes_it() -> None:
    assert state_digest(encoded({"a": 1, "b": 0.5})) == state_digest(encoded({"a": 1, "b": 0.5}))
    assert state_digest(encoded({"a": 0.0})) != state_digest(encoded({"a": -0.0}))
    assert state_digest(encoded({"a": 1})) != state_digest(encoded({"a": 1.0}))
    assert len(state_digest(b"")) == 8


def test_a_digest_is_xxh64_as_its_specification_gives_it() -> None:
    # the empty input's XXH64 (seed 0), from the xxHash specification's test vectors
    assert state_digest(b"") == bytes.fromhex("ef46db3751d8e999")


def test_format_5_digests_are_still_the_keyed_blake2b_they_were() -> None:
    # as format 5 baselines were written (beatlog 0.3.0)
    assert state_digest(encoded({"a": 1}), BLAKE2B) == bytes.fromhex("f9db70fa119ca0cc")
