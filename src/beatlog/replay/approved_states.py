"""Approved robot states: what an approved perception change rebuilds, pinned by digest.

In sensor-level replay an intended perception change (a constant retuned) rebuilds
RS_t otherwise than recorded, often in nearly every cycle. A baseline pins those
states without copying them: for each run of cycles in which perception rebuilds
otherwise, gaps of up to :data:`MAX_GAP` cycles rebuilt as recorded included
(:class:`ApprovedRun`, naming the fields that differ from the recording and giving their
rebuilt values in its first cycle, for review), blocks of up to
:data:`CYCLES_PER_BLOCK` cycles (:class:`DigestBlock`) hold a tag per cycle and a
digest of the block.

A cycle's tag is the first 12 bits of its state's digest
(:func:`~beatlog.replay.approved_state_lines.state_digest`), as two base64 characters:
a state that differs from the approved one is caught in its own cycle, except once in
4,096; the block's digest, of its pinned cycles' whole digests, then catches it at the
block's last pinned cycle (missed once in 2**64). Two characters a cycle keep a
perception retuned for every cycle near 3.2 bytes a cycle; a whole digest would take 11.
"""

from __future__ import annotations

import base64
import bisect
from collections import deque
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any, NamedTuple

from beatlog.replay.approved_state_lines import (
    CYCLES_PER_BLOCK,
    GAP_TAG,
    TAG_CHARS,
    ApprovedRun,
    DigestBlock,
    block_digest,
    state_digest,
)
from beatlog.replay.compare import Comparison

__all__ = [
    "MAX_GAP",
    "ApprovedStateChecker",
    "ApprovedStates",
    "RebuiltState",
    "rebuilt_otherwise",
]

MAX_GAP = 16
"""The most cycles perception may rebuild as recorded inside one run: a gap costs a
tag each, a new run a line of names and values."""
_EXACT = Comparison()


def rebuilt_otherwise(recorded: Mapping[str, Any], rebuilt: Mapping[str, Any]) -> dict[str, Any]:
    """The fields of a rebuilt robot state that differ from the recorded one, bit for
    bit, with their rebuilt values (a field the rebuilt state lacks is left out)."""
    return {
        name: rebuilt[name]
        for name in _EXACT.state_differences(recorded, rebuilt)
        if name in rebuilt
    }


class RebuiltState(NamedTuple):
    """A cycle in which perception rebuilt the robot state otherwise than recorded, as a
    trace collects it."""

    cycle: int
    time_ns: int
    fields: dict[str, Any]
    """The fields that differ from the recording, with their rebuilt values."""
    digest: bytes
    """The :func:`~beatlog.replay.approved_state_lines.state_digest` of the whole rebuilt state."""


@dataclass(frozen=True)
class ApprovedStates:
    """The robot states a baseline approves, pinned by digest: runs, and the blocks that
    cover them, in order (a baseline file's are checked as it is read,
    :class:`~beatlog.replay.approved_state_lines.DigestCoverage`; those pinned from a
    trace cover them as made)."""

    runs: tuple[ApprovedRun, ...] = ()
    blocks: tuple[DigestBlock, ...] = ()

    @classmethod
    def from_rebuilt(cls, states: Iterable[RebuiltState]) -> ApprovedStates:
        """Pin the rebuilt states a trace collected (in cycle order, digested by
        :func:`~beatlog.replay.approved_state_lines.state_digest`)."""
        runs: list[ApprovedRun] = []
        blocks: list[DigestBlock] = []
        for run in _runs(states):
            head, tail = run[0], run[-1]
            fields = sorted({name for state in run for name in state.fields})
            runs.append(
                ApprovedRun(
                    head.cycle, head.time_ns, tail.cycle, len(run), tuple(fields), head.fields
                )
            )
            blocks.extend(_blocks(run))
        return cls(tuple(runs), tuple(blocks))

    @property
    def cycles(self) -> int:
        """How many cycles are pinned."""
        return sum(run.cycles for run in self.runs)


def _tag(digest: bytes) -> str:
    """A cycle's tag: the first 12 bits of its state's digest, as base64 characters."""
    return base64.b64encode(digest[:3]).decode()[:TAG_CHARS]


def _runs(states: Iterable[RebuiltState]) -> Iterator[list[RebuiltState]]:
    """The states in runs whose gaps are at most :data:`MAX_GAP` cycles."""
    run: list[RebuiltState] = []
    for state in states:
        if run and state.cycle - run[-1].cycle - 1 > MAX_GAP:
            yield run
            run = []
        run.append(state)
    if run:
        yield run


def _blocks(run: list[RebuiltState]) -> Iterator[DigestBlock]:
    """A run's blocks: each starts at a pinned cycle and spans at most
    :data:`CYCLES_PER_BLOCK`, ending at the last pinned cycle it reaches."""
    start = 0
    while start < len(run):
        first = run[start].cycle
        end = start
        while end < len(run) and run[end].cycle < first + CYCLES_PER_BLOCK:
            end += 1
        chunk = run[start:end]
        tags = [GAP_TAG] * (chunk[-1].cycle - first + 1)
        for state in chunk:
            tags[state.cycle - first] = _tag(state.digest)
        digest = block_digest(b"".join(state.digest for state in chunk))
        yield DigestBlock(first, run[start].time_ns, "".join(tags), digest)
        start = end


class ApprovedStateChecker:
    """Judges the robot states perception rebuilds against :class:`ApprovedStates`, one
    pinned cycle after another, in cycle order: a pinned cycle by its tag, a block by
    its digest at its last pinned cycle.

    Replay adds a baseline's approved states as it reads them (:meth:`add`), and forgets
    those of the cycles it has judged (:meth:`forget`), so that it holds those of the
    cycles at hand, however many the baseline has. ``pinned`` says whether the baseline pins any
    robot state at all.
    """

    def __init__(
        self, approved: ApprovedStates | None = None, *, pinned: bool | None = None
    ) -> None:
        self.tags: dict[int, str] = {}
        """The tag of each pinned cycle added and not forgotten."""
        self._blocks: deque[tuple[int, int, int]] = deque()
        """The blocks added and not forgotten, in cycle order: the cycle after each, and
        its first and last pinned cycles."""
        self._firsts: set[int] = set()
        """The first pinned cycle of each block."""
        self._finals: dict[int, tuple[DigestBlock, int, int]] = {}
        """Each block by its last pinned cycle, where its digest is checked, with its
        first pinned cycle and how many cycles it pins."""
        self._digests: list[bytes] = []
        """The digests of the cycles judged since the last block opened that agreed with
        their tags, in cycle order: checked with the block's digest where it closes."""
        self._opened = -1
        """The first pinned cycle of the block they are of."""
        self._found: dict[int, str] = {}
        """How the cycles found to differ were found to."""
        self._runs: list[ApprovedRun] = []
        self._starts: list[int] = []
        if approved is not None:
            self.add(approved.runs, approved.blocks)
        self.pinned = bool(self.tags) if pinned is None else pinned

    def add(self, runs: Iterable[ApprovedRun], blocks: Iterable[DigestBlock]) -> None:
        """Add the runs and blocks of the cycles that follow those added (read and
        checked as a baseline's are)."""
        for run in runs:
            self._runs.append(run)
            self._starts.append(run.cycle)
        for block in blocks:
            pinned = {
                block.cycle + at // TAG_CHARS: tag
                for at in range(0, len(block.tags), TAG_CHARS)
                if (tag := block.tags[at : at + TAG_CHARS]) != GAP_TAG
            }
            if not pinned:  # no cycle pinned (a baseline's coverage check refuses it)
                continue
            self.tags.update(pinned)
            first, final = next(iter(pinned)), next(reversed(pinned))  # in cycle order
            self._blocks.append((block.cycle + block.cycles, first, final))
            self._firsts.add(first)
            self._finals[final] = (block, first, len(pinned))

    def forget(self, before: int) -> None:
        """Forget the blocks and runs that end before cycle ``before``."""
        blocks, tags = self._blocks, self.tags
        while blocks and blocks[0][0] <= before:
            _, first, final = blocks.popleft()
            for cycle in range(first, final + 1):
                tags.pop(cycle, None)
            self._firsts.discard(first)
            self._finals.pop(final, None)
        ended = bisect.bisect_left([run.last for run in self._runs], before)
        if ended:
            del self._runs[:ended], self._starts[:ended]

    def __contains__(self, cycle: object) -> bool:
        return cycle in self.tags

    def run_at(self, cycle: int) -> ApprovedRun:
        """The run a pinned cycle is in."""
        return self._runs[bisect.bisect_right(self._starts, cycle) - 1]

    def mismatch(self, cycle: int, encoded: bytes) -> str | None:
        """Judge the robot state rebuilt in pinned ``cycle`` (``encoded`` as a log would),
        each pinned cycle once, in cycle order: how it was found to differ from the
        approved one, ``"by its digest"`` (its tag), or ``"by the digest of cycles
        A–B"`` (its block's, checked at the block's last pinned cycle when every pinned
        cycle of the block was judged, each agreeing with its tag); None when it
        agrees. :meth:`found` asks again.

        :raises KeyError: ``cycle`` is not pinned.
        """
        digest = state_digest(encoded)
        if _tag(digest) != self.tags[cycle]:
            self._found[cycle] = "by its digest"  # reported here, not again for the block
            return "by its digest"
        if cycle in self._firsts:
            self._opened = cycle
            self._digests.clear()
        self._digests.append(digest)
        return self._block_mismatch(cycle) if cycle in self._finals else None

    def found(self, cycle: int, encoded: bytes) -> str | None:
        """How the robot state of a pinned ``cycle`` was found to differ when it was
        judged; one not judged yet is judged now (:meth:`mismatch`)."""
        if cycle in self._found:
            return self._found[cycle]
        return self.mismatch(cycle, encoded)

    def _block_mismatch(self, final: int) -> str | None:
        """How the block closing at pinned cycle ``final`` was found to differ by its
        digest: None when it agrees, or when not every pinned cycle of it was judged,
        each agreeing with its tag (one that disagreed was reported in its own cycle)."""
        block, first, pinned = self._finals[final]
        digests = self._digests
        agreed = self._opened == first and len(digests) == pinned
        packed = b"".join(digests) if agreed else b""
        digests.clear()
        if not agreed or block_digest(packed) == block.digest:
            return None
        found = self._found[final] = f"by the digest of cycles {block.cycle}–{final}"
        return found
