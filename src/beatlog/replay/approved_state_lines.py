"""Approved robot states as a baseline's lines hold them (:class:`ApprovedRun`,
:class:`DigestBlock`), and how a state is digested (:func:`state_digest`).

A state's digest is XXH64, seed 0, eight bytes big-endian, of the state as a log
encodes it (msgpack of the system's robot-state type, its fields in their order, floats
as 64-bit IEEE), so any bit of any field counts, and the replay core, which encodes each
rebuilt state to compare it with the recorded one, digests the same bytes; a block's, of
its states' digests end to end. The digests guard against accidental change, not a hostile
baseline (which could pin anything), so a fast non-cryptographic digest serves. XXH64,
not XXH3: XXH3 digests a state this long with vector instructions (AVX2, AVX-512), which
leave a replay around them slower than their count of instructions says: a re-baselined
perception change costs more CPU with XXH3 than with XXH64 in about as many instructions.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import xxhash

__all__ = [
    "CYCLES_PER_BLOCK",
    "DIGEST_BYTES",
    "GAP_TAG",
    "TAG_CHARS",
    "ApprovedRun",
    "DigestBlock",
    "block_digest",
    "state_digest",
]

DIGEST_BYTES = 8
"""The size of a cycle's state digest and of a block's digest."""
state_digest = xxhash.xxh64_digest
"""The digest of a robot state as a log encodes it
(:func:`~beatlog.log.format.payload_encoder`), bit for bit: eight bytes, big-endian."""
block_digest = xxhash.xxh64_digest
"""A block's digest, of its pinned states' digests, eight bytes each, end to end."""
TAG_CHARS = 2
"""A cycle's tag: the first 12 bits of its digest, as two base64 characters."""
CYCLES_PER_BLOCK = 64
"""The most cycles one block (one line of a baseline) spans."""
GAP_TAG = ".."
"""The tag of a cycle in a gap: judged against the recording, as any cycle not pinned."""


class ApprovedRun(NamedTuple):
    """Cycles in which perception rebuilds the robot state otherwise than recorded, from
    ``cycle`` to ``last`` with gaps (as recorded) of at most
    :data:`~beatlog.replay.approved_states.MAX_GAP` cycles: what a review needs of them."""

    cycle: int
    """The first of them."""
    time_ns: int
    last: int
    """The last of them."""
    cycles: int
    """How many are pinned: ``last - cycle + 1`` less the gaps."""
    fields: tuple[str, ...]
    """The fields that differ from the recording in any of them, sorted."""
    first: dict[str, Any]
    """The fields that differ in the first cycle, with their rebuilt values."""


class DigestBlock(NamedTuple):
    """Up to :data:`CYCLES_PER_BLOCK` consecutive cycles of a run: a tag each
    (:data:`GAP_TAG` for a gap), and the digest of the pinned ones' whole digests."""

    cycle: int
    """The first of them, a pinned one."""
    time_ns: int
    tags: str
    """:data:`TAG_CHARS` a cycle, in cycle order."""
    digest: bytes

    @property
    def cycles(self) -> int:
        """How many cycles the block spans."""
        return len(self.tags) // TAG_CHARS
