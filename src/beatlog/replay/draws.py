"""Random draws made otherwise than recorded, and those an approved baseline approves.

Replay that matches draws (:meth:`~beatlog.replay.random.ReplayRandom.match_draws`)
goes on past a draw made otherwise: each is a :class:`DrawMadeOtherwise`, re-mapped,
new or left unused. A baseline approves them as :class:`ApprovedDraws`, one line each
with the cycles where they happen: what a reviewer wants to read. The verdict judges
each cycle's draws made otherwise exactly (:class:`DrawApprovals`): one not approved in
that cycle, or an approved one not made, is an :class:`UnapprovedDraw` and diverges there.
"""

from __future__ import annotations

import hashlib
from collections import Counter, defaultdict
from collections.abc import Iterable, Sequence
from typing import NamedTuple

import msgspec

from beatlog.log.format import SessionHeader

__all__ = [
    "ApprovedDraws",
    "DrawApprovals",
    "DrawMadeOtherwise",
    "UnapprovedDraw",
    "approved_draws",
    "log_key",
]


class DrawMadeOtherwise(NamedTuple):
    """A draw that replay matching draws made otherwise than recorded: re-mapped, new,
    or a recorded one left unused."""

    behavior: str
    """The behavior that drew it (that drew it in the recording, for one left unused),
    by its name now."""
    recorded: str | None
    """The recorded request as code (``uniform(0.8, 1.6)``; the kind alone in format 1);
    None for a new draw."""
    asked: str | None
    """The request now; None for a recorded draw left unused."""


class ApprovedDraws(NamedTuple):
    """Draws of one behavior made otherwise than recorded, in one way, in ``cycles``: a
    baseline's ``draws`` line."""

    behavior: str
    recorded: str | None
    """The recorded request as code; None for new draws."""
    asked: str | None
    """The request now; None for recorded draws left unused."""
    cycles: tuple[int, ...]
    """The cycles of the draws, in order, a cycle once per draw."""

    @property
    def draw(self) -> DrawMadeOtherwise:
        """The draw made otherwise that these approve."""
        return DrawMadeOtherwise(self.behavior, self.recorded, self.asked)

    def __str__(self) -> str:
        times = len(self.cycles)
        many = "" if times == 1 else "s"
        if self.recorded is None:
            return f"{self.behavior}: {times} new draw{many} of {self.asked}"
        if self.asked is None:
            return f"{self.behavior}: {times} recorded draw{many} of {self.recorded} left unused"
        return f"{self.behavior}: {self.recorded} -> {self.asked}, {times} draw{many} re-mapped"


def approved_draws(made: Iterable[tuple[int, DrawMadeOtherwise]]) -> tuple[ApprovedDraws, ...]:
    """The lines that approve exactly the draws ``made`` otherwise (each with its cycle):
    one per way, in a stable order (by behavior, then request)."""
    cycles: defaultdict[DrawMadeOtherwise, list[int]] = defaultdict(list)
    for cycle, draw in made:
        cycles[draw].append(cycle)
    return tuple(
        ApprovedDraws(*draw, tuple(sorted(cycles[draw])))
        for draw in sorted(cycles, key=lambda d: (d.behavior, d.recorded or "", d.asked or ""))
    )


class UnapprovedDraw(NamedTuple):
    """A cycle's draw made otherwise that the approved baseline does not hold there, or
    one it holds there that replay did not make."""

    draw: DrawMadeOtherwise
    made: bool
    """Whether replay made it (else the baseline holds it and replay did not)."""
    approved_elsewhere: bool
    """Whether the baseline approves it in other cycles."""


class DrawApprovals:
    """The draws made otherwise that a baseline's :class:`ApprovedDraws` allow, cycle
    by cycle."""

    def __init__(self, approved: Iterable[ApprovedDraws]) -> None:
        self._by_cycle: defaultdict[int, Counter[DrawMadeOtherwise]] = defaultdict(Counter)
        """Each cycle's approved draws, with how many of each."""
        self._approved: set[DrawMadeOtherwise] = set()
        for line in approved:
            self._approved.add(line.draw)
            for cycle in line.cycles:
                self._by_cycle[cycle][line.draw] += 1

    def approves(self, cycle: int, made: Sequence[DrawMadeOtherwise]) -> bool:
        """Whether the draws a cycle ``made`` otherwise are exactly the approved ones
        (:meth:`check` finds none)."""
        return self.check(cycle, made) is None

    def check(self, cycle: int, made: Sequence[DrawMadeOtherwise]) -> UnapprovedDraw | None:
        """The first of the draws a cycle ``made`` otherwise that the baseline does not
        hold there, or the first it holds there that replay did not make; None when
        they are exactly the approved ones."""
        allowed = self._by_cycle.get(cycle, Counter())
        counts = Counter(made)
        for draw in made:
            if counts[draw] > allowed[draw]:
                return UnapprovedDraw(draw, True, draw in self._approved)
        for draw, times in allowed.items():
            if counts[draw] < times:
                return UnapprovedDraw(draw, False, True)
        return None


def log_key(header: SessionHeader) -> bytes:
    """What keys the fresh draws of replay matching draws: the recording's identity
    (robot, software, start time, seed), so that two sessions get different fresh
    quantiles and the same session always the same."""
    identity = [header.robot_id, header.software_version, header.start_time_ns, header.random_seed]
    return hashlib.blake2b(msgspec.msgpack.encode(identity), digest_size=32).digest()
