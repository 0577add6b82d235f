"""How strictly replay judges a cycle: exact by default, or with a spec's allowances
(behaviors renamed or ignored, output fields ignored, float tolerances). Replay first
compares bytes; only a cycle whose bytes differ is judged again here, so the allowances
cost nothing while a DTC passes.
"""

from __future__ import annotations

import fnmatch
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import msgspec

from beatlog.log.format import payload_encoder
from beatlog.replay.verdict import StateChange
from beatlog.replay.view import full_state

__all__ = ["WHOLE_STATE", "Comparison", "state_fields"]

_SORTED = msgspec.msgpack.Encoder(order="sorted")
WHOLE_STATE = "(the whole state)"
"""The field named for a robot state that is not a struct or cannot be logged."""


def state_fields(state: Any) -> dict[str, Any]:
    """A robot state's fields as they read back from a log (tuples as lists, numpy
    values as numbers and lists); a state that is no struct, or cannot be logged, is
    one field, :data:`WHOLE_STATE`."""
    try:
        fields = msgspec.msgpack.decode(payload_encoder().encode(full_state(state)))
    except (TypeError, ValueError, msgspec.EncodeError):
        return {WHOLE_STATE: repr(state)}
    return fields if isinstance(fields, dict) else {WHOLE_STATE: fields}


@dataclass(frozen=True)
class Comparison:
    """What counts as "the same" when a replayed cycle is judged against the expected one.

    ``renames`` maps an old name to the current one; it applies to behavior names and to
    states that name a behavior (an arbiter's winner). ``ignore_fields`` are output
    names or globs; ``tolerance`` gives the largest absolute difference accepted per
    output field (lists of numbers are compared element by element), and
    ``state_tolerance`` the same per robot-state field, for the robot state the
    perception step rebuilds in sensor-level replay. A cycle's state changes are
    compared as a set, whatever order the behaviors are listed in.
    """

    renames: Mapping[str, str] = field(default_factory=dict)
    ignore_behaviors: frozenset[str] = frozenset()
    ignore_fields: tuple[str, ...] = ()
    tolerance: Mapping[str, float] = field(default_factory=dict)
    state_tolerance: Mapping[str, float] = field(default_factory=dict)

    def rename(self, name: str) -> str:
        """The current name of a behavior recorded as ``name``."""
        return self.renames.get(name, name)

    def renamed(self, change: StateChange) -> StateChange:
        """An expected state change under the behavior's current name."""
        if not self.renames:
            return change
        return change._replace(behavior=self.rename(change.behavior))

    def changes_agree(self, expected: Sequence[StateChange], actual: Sequence[StateChange]) -> bool:
        """Whether the state changes are the same once ignored behaviors are dropped.

        A cycle's state changes are a set: behaviors may be listed in any order, as
        long as each behavior's own changes come in the same order. ``expected`` is
        under current names (see :meth:`renamed`). States compare as they encode
        (``True`` is not ``1``); a state that names a renamed behavior, such as an
        arbiter's winner, may carry either name.
        """
        return self.first_differing_behavior(expected, actual) is None

    def first_differing_behavior(
        self, expected: Sequence[StateChange], actual: Sequence[StateChange]
    ) -> str | None:
        """The first behavior whose own state changes differ (expected ones first), or
        None when the cycles agree (see :meth:`changes_agree`)."""
        want, got = _by_behavior(self.kept(expected)), _by_behavior(self.kept(actual))
        for behavior in {**want, **got}:
            wanted, changed = want.get(behavior, []), got.get(behavior, [])
            if len(wanted) != len(changed) or not all(
                self._same_state(w.before, g.before) and self._same_state(w.after, g.after)
                for w, g in zip(wanted, changed, strict=True)
            ):
                return behavior
        return None

    def only_order_differs(
        self, expected: Sequence[StateChange], actual: Sequence[StateChange]
    ) -> bool:
        """Whether the state changes agree but list the behaviors in another order."""
        listed = [change.behavior for change in self.kept(expected)]
        return self.changes_agree(expected, actual) and listed != [
            change.behavior for change in self.kept(actual)
        ]

    def _same_state(self, expected: Any, actual: Any) -> bool:
        if isinstance(expected, str) and isinstance(actual, str):
            return expected == actual or self.rename(expected) == actual
        return _SORTED.encode(expected) == _SORTED.encode(actual)

    def kept(self, changes: Iterable[StateChange]) -> list[StateChange]:
        """The state changes of behaviors that are not ignored."""
        ignored = self.ignore_behaviors
        return [change for change in changes if change.behavior not in ignored]

    def outputs_agree(self, expected: Mapping[str, Any], actual: Mapping[str, Any]) -> bool:
        """Whether the outputs are the same field by field, bit for bit unless tolerated."""
        return not _differing(self._fields(expected), self._fields(actual), self.tolerance)

    def state_differences(
        self, expected: Mapping[str, Any], actual: Mapping[str, Any]
    ) -> list[str]:
        """The robot-state fields whose values differ (see :func:`state_fields`): bit
        for bit, or by more than their tolerance. A field on one side only differs."""
        return _differing(expected, actual, self.state_tolerance)

    def _fields(self, outputs: Mapping[str, Any]) -> dict[str, Any]:
        patterns = self.ignore_fields
        return {
            name: value
            for name, value in outputs.items()
            if not any(fnmatch.fnmatchcase(name, pattern) for pattern in patterns)
        }


def _differing(
    expected: Mapping[str, Any], actual: Mapping[str, Any], tolerances: Mapping[str, float]
) -> list[str]:
    """The fields on one side only, or whose values differ bit for bit or, where
    ``tolerances`` gives one, by more than their tolerance."""
    return [
        name
        for name in dict.fromkeys([*expected, *actual])
        if name not in expected
        or name not in actual
        or not _within(expected[name], actual[name], tolerances.get(name))
    ]


def _by_behavior(changes: Iterable[StateChange]) -> dict[str, list[StateChange]]:
    grouped: dict[str, list[StateChange]] = {}
    for change in changes:
        grouped.setdefault(change.behavior, []).append(change)
    return grouped


def _within(expected: Any, actual: Any, tolerance: float | None) -> bool:
    """Whether the values are the same bit for bit or, given a ``tolerance``, within it
    (lists of numbers element by element)."""
    if tolerance is None:
        return _SORTED.encode(expected) == _SORTED.encode(actual)
    if isinstance(expected, Sequence) and not isinstance(expected, str):
        return (
            isinstance(actual, Sequence)
            and not isinstance(actual, str)
            and len(expected) == len(actual)
            and all(_within(e, a, tolerance) for e, a in zip(expected, actual, strict=True))
        )
    if _number(expected) and _number(actual):
        if expected == actual:
            return True
        if math.isnan(expected) or math.isnan(actual):
            return math.isnan(expected) and math.isnan(actual)
        return bool(abs(expected - actual) <= tolerance)
    return _SORTED.encode(expected) == _SORTED.encode(actual)


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)
