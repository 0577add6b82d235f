"""Draws an approved baseline lets replay make otherwise than recorded.

In living replay (:meth:`~beatlog.replay.random.ReplayRandom.live`) each draw made
otherwise is a :class:`~beatlog.replay.random.DrawDifference`. A baseline approves
them as rules, one line each with the cycles where they happen: what a reviewer wants
to read. The verdict judges each cycle's differences exactly (:class:`DrawLedger`): one
that no rule approves in that cycle, or an approved one not made, diverges there.
"""

from __future__ import annotations

import hashlib
from collections import Counter, defaultdict
from collections.abc import Iterable, Sequence
from typing import NamedTuple

import msgspec

from beatlog.log.format import SessionHeader
from beatlog.replay.random import DrawDifference

__all__ = ["DrawLedger", "DrawRule", "Unapproved", "draw_rules", "log_key"]


class DrawRule(NamedTuple):
    """Draws of one behavior made otherwise than recorded, in one way, in ``cycles``."""

    behavior: str
    recorded: str | None
    """The recorded request as code; None for new draws."""
    asked: str | None
    """The request now; None for recorded draws left unused."""
    cycles: tuple[int, ...]
    """The cycles of the draws, in order, a cycle once per draw."""

    @property
    def difference(self) -> DrawDifference:
        """The difference this rule approves."""
        return DrawDifference(self.behavior, self.recorded, self.asked)

    def __str__(self) -> str:
        times = len(self.cycles)
        many = "" if times == 1 else "s"
        if self.recorded is None:
            return f"{self.behavior}: {times} new draw{many} of {self.asked}"
        if self.asked is None:
            return f"{self.behavior}: {times} recorded draw{many} of {self.recorded} left unused"
        return f"{self.behavior}: {self.recorded} -> {self.asked}, {times} draw{many} re-mapped"


def draw_rules(differences: Iterable[tuple[int, DrawDifference]]) -> tuple[DrawRule, ...]:
    """The rules that approve exactly ``differences`` (each with its cycle): one per kind
    of difference, in a stable order (by behavior, then request)."""
    cycles: defaultdict[DrawDifference, list[int]] = defaultdict(list)
    for cycle, difference in differences:
        cycles[difference].append(cycle)
    return tuple(
        DrawRule(*difference, tuple(sorted(cycles[difference])))
        for difference in sorted(
            cycles, key=lambda d: (d.behavior, d.recorded or "", d.asked or "")
        )
    )


class Unapproved(NamedTuple):
    """A cycle's draw that differs from what the approved baseline holds."""

    difference: DrawDifference
    made: bool
    """Whether replay made it (else the baseline holds it and replay did not)."""
    approved_elsewhere: bool
    """Whether the baseline approves it in other cycles."""


class DrawLedger:
    """The draws an approved baseline's rules allow, cycle by cycle."""

    def __init__(self, rules: Iterable[DrawRule]) -> None:
        rules = list(rules)
        self._by_cycle: defaultdict[int, Counter[DrawDifference]] = defaultdict(Counter)
        """Each cycle's approved differences, with how many of each."""
        for rule in rules:
            for cycle in rule.cycles:
                self._by_cycle[cycle][rule.difference] += 1
        self._approved = frozenset(rule.difference for rule in rules)
        self.cycles = frozenset(self._by_cycle)
        """The cycles where the baseline holds draws made otherwise than recorded."""

    def approves(self, cycle: int, differences: Sequence[DrawDifference]) -> bool:
        """Whether a cycle's differences are exactly the approved ones (:meth:`check`
        finds none)."""
        if len(differences) == 1:  # the usual
            return self._by_cycle.get(cycle) == {differences[0]: 1}
        return Counter(differences) == self._by_cycle.get(cycle, Counter())

    def check(self, cycle: int, differences: Sequence[DrawDifference]) -> Unapproved | None:
        """The first of a cycle's differences the baseline does not hold there, or the
        first it holds there that replay did not make; None when they are exactly the
        approved ones."""
        allowed = self._by_cycle.get(cycle, Counter())
        made = Counter(differences)
        for difference in differences:
            if made[difference] > allowed[difference]:
                return Unapproved(difference, True, difference in self._approved)
        for difference, times in allowed.items():
            if made[difference] < times:
                return Unapproved(difference, False, True)
        return None


def log_key(header: SessionHeader) -> bytes:
    """What keys the fresh draws of living replay: the recording's identity (robot,
    software, start time, seed), so that two sessions get different fresh luck and the
    same session always the same."""
    identity = [header.robot_id, header.software_version, header.start_time_ns, header.random_seed]
    return hashlib.blake2b(msgspec.msgpack.encode(identity), digest_size=32).digest()
