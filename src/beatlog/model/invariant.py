"""Invariants: properties of the robot's behavior that must hold at every heartbeat,
whatever the recording ("never walk while fallen"), checked in every replayed cycle and,
on request, in every recorded one.

An invariant is a plain callable given a :class:`Cycle`. It holds unless it raises
:class:`AssertionError` (a plain ``assert``, whose message says why) or returns a false
value other than None (``False``, numpy's ``False``). Any other exception is a failure
of the invariant's own code, reported as such. A class named as an invariant is
instantiated afresh for each replay, so that one which looks across cycles ("a low
battery leads to docking within 20 s") keeps its own state.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

from beatlog.model.cycle import RandomDraw, StateChange

__all__ = ["Cycle", "Invariant"]


class Cycle(NamedTuple):
    """What one cycle had, replayed or live, as an invariant reads it: read-only, and a
    named tuple, which costs the least to build (a replay builds one every cycle)."""

    cycle: int
    """The heartbeat's index t, from 0."""
    time_ns: int
    """Robot time at the end of the cycle, in ns."""
    dt_ns: int
    """HB_t, the cycle's heartbeat interval, in ns."""
    robot_state: Any
    """RS_t as the behaviors saw it."""
    states: Mapping[str, Any]
    """Every behavior's state after the update, by name, in catalogue order."""
    changes: tuple[StateChange, ...]
    """BS_t: the behaviors' state changes in this cycle."""
    outputs: Mapping[str, Any]
    """What the behaviors reported this cycle, e.g. motor commands."""
    draws: tuple[RandomDraw, ...]
    """The random numbers drawn this cycle, each with the behavior that drew it."""

    @property
    def time(self) -> float:
        """Robot time at the end of the cycle in seconds."""
        return self.time_ns / 1e9

    @property
    def dt(self) -> float:
        """The cycle's heartbeat interval in seconds."""
        return self.dt_ns / 1e9


Invariant = Callable[[Cycle], object]
"""A property checked at every cycle: it holds unless it raises ``AssertionError`` or
returns a false value other than None."""
