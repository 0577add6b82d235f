"""A window of cycles, as a DTC's ``start_cycle`` and ``end_cycle`` set it: a replay
judged from one cycle to another (both inclusive), the cycles before it replayed as
recorded to rebuild the behaviors' state (or, from a fresh start, not replayed at all),
judged only by whether replay can go on past them, and none after it read.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path

from beatlog.errors import WindowError
from beatlog.log.format import CycleRecord
from beatlog.log.reader import LogStatus
from beatlog.replay.core import Replayer
from beatlog.replay.verdict import Divergence, DivergenceKind

__all__ = ["Window"]


class Window:
    """The cycles from ``start`` to ``end`` (None: the log's last), with ``fresh`` a
    fresh start at ``start``."""

    def __init__(self, start: int = 0, end: int | None = None, *, fresh: bool = False) -> None:
        self.start = start
        self.end = end
        self.fresh_from = start if fresh else 0
        """The cycle the behaviors start from rest at (0: the log's start)."""
        self.closed = False
        """Whether the batches stopped at the window's end, the rest of the log unread."""
        self.start_ns = 0
        """Robot time where the window opens."""
        self.before = [0, 0, 0, 0]
        """What the replay core counted before the window opened (state changes, outputs
        and draws of the cycles that agreed at once, samples perceived): not judged."""

    def batches(
        self, batches: Iterator[Sequence[CycleRecord]], replayer: Replayer
    ) -> Iterator[Sequence[CycleRecord]]:
        """``batches``, from ``replayer``'s next cycle on, cut where the window opens (what
        the replay core counted before it noted then) and after it ends, none read after."""
        cycle = replayer.executor.context.cycle + 1
        for batch in batches:
            at, cycle = cycle, cycle + len(batch)
            kept = batch
            if self.end is not None and cycle > self.end:
                self.closed = True
                kept = batch[: self.end + 1 - at]
            if self.start and at <= self.start < at + len(kept):
                if self.start > at:
                    yield kept[: self.start - at]
                self.start_ns = replayer.executor.clock.now_ns
                self.before = [*replayer.agreed, replayer.samples_perceived]
                kept = kept[self.start - at :]
            yield kept
            if self.closed:
                return

    def log_ended(
        self,
        status: LogStatus | None,
        where: Path,
        cycle: int,
        time_ns: int,
        *,
        allow_truncated: bool,
    ) -> Divergence | None:
        """The divergence of a log that stopped before the recording closed it (``status``;
        None: the window closed before the log's end) where that is not allowed, replay
        having got to ``cycle`` at ``time_ns``; else refuse a window that the log does not
        hold, ``where`` (the spec that set it, or the log) named.

        :raises beatlog.errors.WindowError: it starts or ends past the last cycle.
        """
        if status is None:
            return None
        if not status.complete and not allow_truncated:
            return Divergence(
                kind=DivergenceKind.LOG_ENDED,
                cycle=min(cycle, status.cycles),
                time_ns=time_ns,
                message=f"the log ends early ({status.describe()}); if the session ended there "
                "(a crash), accept what it holds with --allow-truncated (in a spec: "
                "allow_truncated = true)",
            )
        for key, last in (("end_cycle", self.end), ("start_cycle", self.start or None)):
            if last is not None and last >= status.cycles:
                past = f"{last} is past the log's last cycle ({status.cycles - 1})"
                raise WindowError(where, f"{key} {past}")
        return None

    def arguments(self) -> list[str]:
        """The options of a ``beatlog replay`` command that set this window."""
        return [
            *(["--start-cycle", str(self.start)] if self.start else []),
            *([] if self.end is None else ["--end-cycle", str(self.end)]),
            *(["--fresh-start"] if self.fresh_from else []),
        ]

    def note(self) -> str:
        """What a reader should know of the cycles before the window: replayed, not
        judged, not counted; or, from a fresh start, not replayed at all."""
        if not self.start:
            return ""
        cycles = f"{self.start} cycle{'' if self.start == 1 else 's'}"
        if self.fresh_from:
            start = f"fresh start: the behaviors start from rest at cycle {self.start}"
            return f"{start}; {cycles} before it not replayed"
        return f"{cycles} before the window replayed as recorded to rebuild the state, unjudged"
