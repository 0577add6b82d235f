"""Spotting a rename: two traces that differ only by a one-to-one substitution of names."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import msgspec

from beatlog.replay.verdict import StateChange

__all__ = ["propose_renames"]

_ENCODE = msgspec.msgpack.encode


def propose_renames(
    cycles: Iterable[tuple[Sequence[StateChange], Sequence[StateChange]]],
) -> dict[str, str]:
    """The behavior rename map (old → new) that turns every expected cycle into the actual.

    ``cycles`` pairs each cycle's expected state changes with the actual ones. The
    substitution of behavior names must hold across all of them and be one-to-one; a
    state may differ only where it names a renamed behavior (an arbiter's winner).
    Returns an empty map when the traces differ in any other way, or not at all.
    """
    forward: dict[str, str] = {}
    backward: dict[str, str] = {}
    states: set[tuple[str, str]] = set()
    for expected, actual in cycles:
        if len(expected) != len(actual):
            return {}
        for want, got in zip(expected, actual, strict=True):
            old, new = want.behavior, got.behavior
            if forward.setdefault(old, new) != new or backward.setdefault(new, old) != old:
                return {}
            for before, after in ((want.before, got.before), (want.after, got.after)):
                if isinstance(before, str) and isinstance(after, str):
                    if before != after:
                        states.add((before, after))
                elif _ENCODE(before) != _ENCODE(after):
                    return {}
    if any(forward.get(old) != new for old, new in states):
        return {}
    return {old: new for old, new in forward.items() if old != new}
