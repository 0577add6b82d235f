"""What a session log holds, in figures: for ``beatlog show`` and for people reading logs."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import msgspec
import numpy as np

from beatlog.errors import CorruptLogError
from beatlog.log.format import EMPTY_LIST, SessionEnd, SessionHeader
from beatlog.log.reader import LogStatus, SessionLogReader

__all__ = ["LogSummary", "summarize"]


@dataclass(frozen=True)
class LogSummary:
    """Figures of one session log."""

    path: Path
    header: SessionHeader
    status: LogStatus
    end: SessionEnd | None
    cycles: int
    robot_time_ns: int
    heartbeat_mean_ms: float
    heartbeat_p99_ms: float
    heartbeat_max_ms: float
    late_beats: int
    """Heartbeat intervals longer than 1.5 periods."""
    transitions: dict[str, int]
    """State changes per behavior, in catalogue order."""
    random_draws: dict[str, int]
    """Random numbers drawn per kind."""


class _Change(msgspec.Struct, array_like=True):
    behavior: int
    before: object
    after: object


class _Draw(msgspec.Struct, array_like=True):
    actor: int
    kind: str
    value: msgspec.Raw


def summarize(path: str | Path) -> LogSummary:
    """Read a whole log and gather its figures."""
    changes_decoder = msgspec.msgpack.Decoder(list[_Change])
    draws_decoder = msgspec.msgpack.Decoder(list[_Draw])
    with SessionLogReader(path) as reader:
        header = reader.header
        intervals: list[int] = []
        transitions = Counter[int]()
        draws = Counter[str]()
        for batch in reader.batches():
            for cycle in batch:
                intervals.append(cycle.heartbeat_ns)
                try:
                    if cycle.state_changes != EMPTY_LIST:
                        transitions.update(
                            c.behavior for c in changes_decoder.decode(cycle.state_changes)
                        )
                    if cycle.random_numbers != EMPTY_LIST:
                        draws.update(d.kind for d in draws_decoder.decode(cycle.random_numbers))
                except msgspec.DecodeError as exc:
                    raise CorruptLogError(
                        reader.path, f"damaged cycle {len(intervals) - 1}: {exc}"
                    ) from None
        status, end = reader.status, reader.end
    hb = np.asarray(intervals, dtype=np.float64) / 1e6 if intervals else np.zeros(1)
    names = header.behaviors
    return LogSummary(
        path=Path(path),
        header=header,
        status=status,
        end=end,
        cycles=len(intervals),
        robot_time_ns=sum(intervals),
        heartbeat_mean_ms=float(hb.mean()),
        heartbeat_p99_ms=float(np.percentile(hb, 99)),
        heartbeat_max_ms=float(hb.max()),
        late_beats=int(np.count_nonzero(hb > 1.5 * header.period_ns / 1e6)),
        transitions={name: transitions[index] for index, name in enumerate(names)},
        random_draws=dict(sorted(draws.items())),
    )
