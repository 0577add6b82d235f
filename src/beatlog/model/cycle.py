"""One cycle of a system, the same on the robot and in replay: update, then observe.

The executor advances the heartbeat clock by HB_t, updates the behaviors from RS_t
and diffs every behavior's state in catalogue order, giving BS_t.
"""

from __future__ import annotations

from typing import Any

from beatlog.log.format import StateChangeRecord
from beatlog.model.behavior import System
from beatlog.model.clock import SimulatedHeartbeat
from beatlog.model.context import Context
from beatlog.model.random import RandomSource

__all__ = ["CycleExecutor"]


class CycleExecutor:
    """Drives a system cycle by cycle and reports its behavior state changes."""

    def __init__(self, system: System, random: RandomSource) -> None:
        self.system = system
        catalogue = system.behaviors
        self.behavior_ids = list(catalogue)
        self._behaviors = list(catalogue.values())
        self._states = [behavior.state for behavior in self._behaviors]
        self.clock = SimulatedHeartbeat()
        self.context = Context(random)
        random.bind(self.context)

    def step(self, interval_ns: int, state: Any) -> list[StateChangeRecord]:
        """Run cycle t: advance time by HB_t, update from RS_t, return BS_t."""
        context = self.context
        context.cycle += 1
        context.dt_ns = interval_ns
        self.clock.advance(interval_ns)
        context.time_ns = self.clock.now_ns
        context.actor = -1
        if context.outputs:
            context.outputs = {}
        self.system.update(state, context)
        changes: list[StateChangeRecord] = []
        states = self._states
        for index, behavior in enumerate(self._behaviors):
            after = behavior.state
            before = states[index]
            if after is not before and after != before:
                changes.append((index, before, after))
                states[index] = after
        return changes
