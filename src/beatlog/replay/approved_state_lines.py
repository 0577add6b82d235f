"""Approved robot states as a baseline's lines hold them (:class:`ApprovedRun`,
:class:`DigestBlock`), how a state is digested (:func:`state_digest`), and the check, as
a baseline is read, that the blocks cover their runs in order (:class:`DigestCoverage`).

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

import heapq
import re
from collections.abc import Iterable
from typing import Any, NamedTuple

import xxhash

__all__ = [
    "CYCLES_PER_BLOCK",
    "DIGEST_BYTES",
    "GAP_TAG",
    "TAG_CHARS",
    "ApprovedRun",
    "DigestBlock",
    "DigestCoverage",
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
_TAGS = re.compile(rf"(?:[A-Za-z0-9+/]{{{TAG_CHARS}}}|{re.escape(GAP_TAG)})*")
"""Tags one after another: each :data:`TAG_CHARS` base64 digits, or :data:`GAP_TAG`."""


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


class DigestCoverage:
    """Checks that blocks of digests cover their runs, in order, as a baseline is read:
    a part of its runs and blocks at a time (:meth:`add`), then :meth:`end`. Each says
    why they do not, if they do not."""

    def __init__(self) -> None:
        self._run: ApprovedRun | None = None
        """The run whose blocks are read now."""
        self._start = 0
        """The cycle its next block starts at."""
        self._pinned = 0
        """How many cycles its blocks pinned so far."""

    def add(self, runs: Iterable[ApprovedRun], blocks: Iterable[DigestBlock]) -> str | None:
        """Take the next runs and blocks, those of a part of a baseline."""
        lines: Iterable[tuple[int, int, int, ApprovedRun | DigestBlock]] = heapq.merge(
            ((run.cycle, 0, index, run) for index, run in enumerate(runs)),
            ((block.cycle, 1, index, block) for index, block in enumerate(blocks)),
        )
        for *_, line in lines:
            problem = self._open(line) if isinstance(line, ApprovedRun) else self._block(line)
            if problem is not None:
                return problem
        return None

    def end(self) -> str | None:
        """Take the end of the baseline."""
        return self._close()

    def _open(self, run: ApprovedRun) -> str | None:
        where = f"the robot-state run from cycle {run.cycle}"
        after = self._start if self._run is None else self._run.last + 1
        if run.cycle < after or run.last < run.cycle:
            return f"{where} is out of order"
        problem = self._close()
        if problem is not None:
            return problem
        if not run.first or not set(run.first) <= set(run.fields):
            return f"{where} names no fields that differ in its first cycle"
        self._run, self._start, self._pinned = run, run.cycle, 0
        return None

    def _block(self, block: DigestBlock) -> str | None:
        run = self._run
        if run is None or block.cycle > run.last:
            return f"the digests from cycle {block.cycle} are in no robot-state run"
        where = f"the robot-state run from cycle {run.cycle}"
        if block.cycle < self._start or (self._pinned == 0 and block.cycle != run.cycle):
            return f"{where} has its digests of cycle {block.cycle} out of place"
        cycles = block.cycles
        if not (_TAGS.fullmatch(block.tags) and 0 < cycles <= CYCLES_PER_BLOCK):
            return f"{where} has not 1 to {CYCLES_PER_BLOCK} tags from cycle {block.cycle}"
        self._start = block.cycle + cycles
        self._pinned += cycles - block.tags.count(GAP_TAG)
        return None

    def _close(self) -> str | None:
        """Check the run read last, and leave it."""
        run, self._run = self._run, None
        if run is None:
            return None
        where = f"the robot-state run from cycle {run.cycle}"
        if self._start != run.last + 1:
            return f"{where} has digests that do not end at its last cycle, {run.last}"
        if self._pinned != run.cycles:
            return f"{where} says {run.cycles} cycles, its digests pin {self._pinned}"
        return None
