"""One cycle of a system, the same on the robot and in replay: update, then observe.

The executor advances the heartbeat clock by HB_t, updates the behaviors from RS_t
and diffs every behavior's state in catalogue order, giving BS_t.
"""

from __future__ import annotations

from operator import attrgetter
from typing import Any

from beatlog.log.format import StateChangeRecord
from beatlog.model.behavior import System
from beatlog.model.clock import SimulatedHeartbeat
from beatlog.model.context import Context
from beatlog.model.random import RandomSource

__all__ = ["CycleExecutor"]

_state_of = attrgetter("state")


class CycleExecutor:
    """Drives a system cycle by cycle and reports its behavior state changes."""

    def __init__(self, system: System, random: RandomSource) -> None:
        self.system = system
        catalogue = system.behaviors
        self.behavior_ids = list(catalogue)
        self._behaviors = list(catalogue.values())
        self._states = list(map(_state_of, self._behaviors))
        self._update = system.update
        self.clock = SimulatedHeartbeat()
        self.context = Context(random)
        random.bind(self.context)

    def step(self, interval_ns: int, state: Any) -> list[StateChangeRecord]:
        """Run cycle t: advance time by HB_t, update from RS_t, return BS_t."""
        context = self.context
        context.cycle += 1
        context.dt_ns = interval_ns
        context.time_ns = self.clock.advance(interval_ns)
        context.actor = -1
        if context.outputs:
            context.outputs = {}
        self._update(state, context)
        now = list(map(_state_of, self._behaviors))
        states = self._states
        if now == states:  # the common case, compared in C: same objects or equal values
            return []
        changes: list[StateChangeRecord] = []
        for index, after in enumerate(now):
            before = states[index]
            if after is not before and after != before:
                changes.append((index, before, after))
                states[index] = after
        return changes
