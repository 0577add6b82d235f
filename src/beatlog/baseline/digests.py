"""The check, as a baseline is read a part at a time, that its blocks of digests cover
their robot-state runs in order (:class:`DigestCoverage`)."""

from __future__ import annotations

import heapq
import re
from collections.abc import Iterable

from beatlog.replay.approved_state_lines import (
    CYCLES_PER_BLOCK,
    GAP_TAG,
    TAG_CHARS,
    ApprovedRun,
    DigestBlock,
)

__all__ = ["DigestCoverage"]

_TAGS = re.compile(rf"(?:[A-Za-z0-9+/]{{{TAG_CHARS}}}|{re.escape(GAP_TAG)})*")
"""Tags one after another: each :data:`TAG_CHARS` base64 digits, or :data:`GAP_TAG`."""


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
