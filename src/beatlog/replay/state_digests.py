"""How a baseline's approved robot states are digested
(:mod:`beatlog.replay.approved_states`): XXH64, seed 0, of a state as a log encodes it,
and of a block's states' digests end to end.

The digests guard against accidental change, not a hostile baseline (which could pin
anything), so a fast non-cryptographic digest serves. XXH64, not XXH3: XXH3 digests a
state this long with vector instructions (AVX2, AVX-512), which leave a replay around
them slower than their count of instructions says: a re-baselined perception change
costs more CPU with XXH3 than with XXH64 in about as many instructions.
"""

from __future__ import annotations

import xxhash

__all__ = ["DIGEST_BYTES", "block_digest", "state_digest", "state_number"]

DIGEST_BYTES = 8
"""The size of a cycle's state digest and of a block's digest."""
state_number = xxhash.xxh64_intdigest
"""A state's digest as an unsigned 64-bit int, as the replay core compares it."""
block_digest = xxhash.xxh64_digest
"""A block's digest, of its pinned states' digests, eight bytes each, end to end."""


def state_digest(encoded: bytes) -> bytes:
    """The digest of a robot state as a log encodes it
    (:func:`~beatlog.log.format.payload_encoder`), bit for bit: eight bytes, big-endian."""
    return xxhash.xxh64_digest(encoded)
