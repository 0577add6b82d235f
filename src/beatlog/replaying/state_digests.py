"""How a baseline's pins digest robot states (:mod:`beatlog.replaying.pins`), by format.

Baselines of format 6 on digest a state, as a log encodes it, with XXH64
(:data:`XXH64`); formats 4 and 5 with a keyed BLAKE2b (:data:`BLAKE2B`), seven times as
dear, still judged as they were written. The pins guard against accidental change,
not a hostile baseline (which could pin anything), so a fast non-cryptographic digest
serves. XXH64, not XXH3: XXH3 digests a state this long with vector instructions (AVX2,
AVX-512), which leave a replay around them slower than their count of instructions says:
a re-baselined perception change costs more CPU with XXH3 than with XXH64 in about as
many instructions.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from typing import NamedTuple

import xxhash

__all__ = ["BLAKE2B", "DIGEST_BYTES", "XXH64", "PinDigest", "state_digest"]

DIGEST_BYTES = 8
"""The size of a cycle's state digest and of a block's digest."""


class PinDigest(NamedTuple):
    """How a baseline's pins digest robot states: a state's digest, as an unsigned
    64-bit int (its eight bytes big-endian), and a block's, of its states' digests."""

    name: str
    state: Callable[[bytes], int]
    block: Callable[[bytes], bytes]
    """Of the block's pinned states' digests, eight bytes each big-endian, end to end."""


XXH64 = PinDigest("XXH64", xxhash.xxh64_intdigest, xxhash.xxh64_digest)
"""The pins of baseline format 6 on: XXH64, seed 0."""
_KEY = b"beatlog robot state"
_HASHER = hashlib.blake2b(digest_size=DIGEST_BYTES, key=_KEY)


def _blake2b_state(encoded: bytes) -> int:
    hasher = _HASHER.copy()  # cheaper than keying a new one
    hasher.update(encoded)
    return int.from_bytes(hasher.digest())


def _blake2b_block(digests: bytes) -> bytes:
    return hashlib.blake2b(digests, digest_size=DIGEST_BYTES, key=_KEY).digest()


BLAKE2B = PinDigest("BLAKE2b", _blake2b_state, _blake2b_block)
"""The pins of baseline formats 4 and 5: BLAKE2b of eight bytes, keyed with
``b"beatlog robot state"``."""


def state_digest(encoded: bytes, scheme: PinDigest = XXH64) -> bytes:
    """The digest of a robot state as a log encodes it
    (:func:`~beatlog.log.format.payload_encoder`), bit for bit."""
    return scheme.state(encoded).to_bytes(DIGEST_BYTES)
