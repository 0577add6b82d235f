"""What an intended change does to a DTC against today's baseline (approved, else
recorded): the state changes, outputs and draws it loses, those it gains, and how much
of the session stays closed loop.

Each loss is kept apart, to be named to the reviewer in its own words, never folded
into a count. A state change is matched with one of its behavior and transition in its
own cycle, else with the next left over (it has *moved*); those left without a
counterpart are lost or new.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import NamedTuple

from beatlog.replay.baseline import ABSENT, TracedOutput, TracedStateChange
from beatlog.replay.draws import ApprovedDraws
from beatlog.replay.verdict import StateChange

__all__ = ["Loss", "LossKind", "Shift", "Trace", "shift"]

Trace = tuple[Sequence[TracedStateChange], Sequence[TracedOutput]]
"""A whole trace: every state change and the outputs (as the cycles where a field changed)."""


class LossKind(StrEnum):
    """What a loss takes away."""

    STATE_CHANGES = "state changes"
    """A behavior's state changes that no longer happen."""
    OUTPUT = "output"
    """An output field no longer output at all."""
    DRAWS = "draws"
    """Recorded draws no longer made."""


class Loss(NamedTuple):
    """Something today's baseline has that a new one no longer has."""

    kind: LossKind
    name: str
    """The behavior (state changes, draws) or the output field."""
    cycles: tuple[int, ...]
    """Where it happens today (a state change or draw: once each)."""
    silent: bool = False
    """State changes: the behavior never changes state in the new baseline."""
    request: str | None = None
    """Draws: the recorded request, as code."""


@dataclass(frozen=True)
class Shift:
    """What a new baseline loses and gains against today's."""

    losses: tuple[Loss, ...]
    lost: int
    """State changes that no longer happen."""
    gained: int
    """State changes that happen now and did not."""
    moved: int
    """State changes that happen in another cycle now."""
    cycles: int
    """The cycles of the session."""
    open_loop: int | None
    """The first cycle where the new baseline leaves the recording, if it does."""

    @property
    def closed_loop(self) -> int:
        """The cycles before the new baseline leaves the recording."""
        return self.cycles if self.open_loop is None else min(self.open_loop, self.cycles)


def shift(
    before: Trace,
    after: Trace,
    *,
    cycles: int,
    open_loop: int | None,
    draws_before: Iterable[ApprovedDraws] = (),
    draws_after: Iterable[ApprovedDraws] = (),
) -> Shift:
    """How the whole trace ``after`` differs from ``before``, with the draws each lets
    replay make otherwise than recorded; ``cycles`` is the session's length and
    ``open_loop`` the cycle where ``after`` leaves the recording."""
    was, now = _occurrences(before[0]), _occurrences(after[0])
    losses: list[Loss] = []
    lost = gained = moved = 0
    for behavior in sorted(was.keys() | now.keys()):
        old, new = was.get(behavior, {}), now.get(behavior, {})
        gone: list[int] = []
        for transition in old.keys() | new.keys():
            was_at, now_at = Counter(old.get(transition, ())), Counter(new.get(transition, ()))
            first, then = sorted((was_at - now_at).elements()), sorted((now_at - was_at).elements())
            moved += min(len(first), len(then))
            gone.extend(first[len(then) :])
            gained += max(0, len(then) - len(first))
        lost += len(gone)
        if gone:
            losses.append(
                Loss(LossKind.STATE_CHANGES, behavior, tuple(sorted(gone)), silent=not new)
            )
    output, kept = _output_fields(before[1]), _output_fields(after[1])
    losses.extend(
        Loss(LossKind.OUTPUT, name, tuple(output[name])) for name in sorted(output.keys() - kept)
    )
    approved = set(draws_before)
    losses.extend(
        Loss(LossKind.DRAWS, rule.behavior, rule.cycles, request=rule.recorded)
        for rule in draws_after
        if rule.asked is None and rule not in approved
    )
    return Shift(tuple(losses), lost, gained, moved, cycles, open_loop)


def _occurrences(changes: Iterable[TracedStateChange]) -> dict[str, dict[StateChange, list[int]]]:
    """The cycles of each behavior's state changes, by transition, in order."""
    found: dict[str, dict[StateChange, list[int]]] = {}
    for traced in changes:
        change = traced.change
        found.setdefault(change.behavior, {}).setdefault(change, []).append(traced.cycle)
    return found


def _output_fields(outputs: Iterable[TracedOutput]) -> dict[str, list[int]]:
    """The output fields given a value, each with the cycles where it took one."""
    fields: dict[str, list[int]] = {}
    for output in outputs:
        if output.value is not ABSENT:
            fields.setdefault(output.field, []).append(output.cycle)
    return fields
