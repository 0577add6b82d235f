"""Draws an approved baseline lets replay make otherwise than recorded.

In living replay (:meth:`~beatlog.model.random.ReplayRandom.live`) a behavior that
asks for other draws than were recorded goes on, and each draw made otherwise is a
:class:`~beatlog.model.random.DrawDifference`. A baseline approves them as rules with
counts, one line each however long the session (``wander: uniform(0.8, 1.6) ->
uniform(0.7, 1.5), 14 draws``): small, and what a reviewer wants to read. The verdict
keeps a :class:`DrawLedger`: a difference no rule approves, or one more than approved,
diverges in its cycle; approved draws that never came diverge at the end.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from typing import NamedTuple

from beatlog.model.random import DrawDifference

__all__ = ["DrawLedger", "DrawRule", "draw_rules"]


class DrawRule(NamedTuple):
    """Draws of one behavior made otherwise than recorded, in one way, ``times`` times."""

    behavior: str
    recorded: str | None
    """The recorded request as code; None for new draws."""
    asked: str | None
    """The request now; None for recorded draws left unused."""
    times: int

    @property
    def difference(self) -> DrawDifference:
        """The difference this rule approves."""
        return DrawDifference(self.behavior, self.recorded, self.asked)

    def __str__(self) -> str:
        many = "" if self.times == 1 else "s"
        if self.recorded is None:
            return f"{self.behavior}: {self.times} new draw{many} of {self.asked}"
        if self.asked is None:
            return (
                f"{self.behavior}: {self.times} recorded draw{many} of {self.recorded} left unused"
            )
        return (
            f"{self.behavior}: {self.recorded} -> {self.asked}, {self.times} draw{many} re-mapped"
        )


def draw_rules(differences: Iterable[DrawDifference]) -> tuple[DrawRule, ...]:
    """The rules that approve exactly ``differences``: one per kind of difference, with
    its count, in a stable order (by behavior, then request)."""
    counted = Counter(differences)
    return tuple(
        DrawRule(*difference, counted[difference])
        for difference in sorted(
            counted, key=lambda d: (d.behavior, d.recorded or "", d.asked or "")
        )
    )


class DrawLedger:
    """What an approved baseline's draw rules still allow, as replay goes."""

    def __init__(self, rules: Iterable[DrawRule]) -> None:
        self._left: Counter[DrawDifference] = Counter()
        for rule in rules:
            self._left[rule.difference] += rule.times
        self._approved = frozenset(self._left)

    def unapproved(self, differences: Sequence[DrawDifference]) -> DrawDifference | None:
        """The first of a cycle's differences that the rules do not allow (none left)."""
        wanted: Counter[DrawDifference] = Counter()
        for difference in differences:
            wanted[difference] += 1
            if wanted[difference] > self._left[difference]:
                return difference
        return None

    def take(self, differences: Sequence[DrawDifference]) -> bool:
        """Use the rules for a cycle's differences, if they allow them all."""
        if self.unapproved(differences) is not None:
            return False
        self._left.subtract(differences)
        return True

    def approves(self, difference: DrawDifference) -> bool:
        """Whether a rule approves ``difference`` at all (however many are left)."""
        return difference in self._approved

    def left(self) -> tuple[DrawRule, ...]:
        """The approved draws replay has not made (yet)."""
        return draw_rules(self._left.elements())
