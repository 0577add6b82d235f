"""One cycle of a system, the same on the robot and in replay: update, then observe.

The executor advances the heartbeat clock by HB_t, updates the behaviors from RS_t
and diffs every behavior's state in catalogue order, giving BS_t.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any

from beatlog.log.format import StateChangeRecord
from beatlog.model.behavior import Behavior, System
from beatlog.model.clock import SimulatedHeartbeat
from beatlog.model.context import Context
from beatlog.model.random import RandomSource

__all__ = ["CycleExecutor", "Pause", "Update", "state_differ"]

Update = Callable[[Any, Context], None]
"""A system's update: the behaviors step from RS_t with the context of the cycle."""
Pause = Callable[[Update, Any, Context], None]
"""Takes the place of one update: given it, RS_t and the context, it must run it."""


def state_differ(behaviors: Sequence[Behavior]) -> Callable[[], list[StateChangeRecord]]:
    """A function that returns the behaviors' state changes since its last call (since
    it was made, the first time): BS_t, as ``(index, before, after)`` in catalogue order.

    A state counts as changed when it is another object that is not equal to the one
    seen last (which is kept otherwise: ``1`` then ``True`` then ``2`` is one change,
    from ``1`` to ``2``). The function's source is written out for the catalogue (as
    :mod:`dataclasses` writes an ``__init__``), from nothing but the catalogue's size:
    each behavior's state is read by an attribute access of its own, which the
    interpreter specialises for that behavior's class, and compared by identity with
    the state last seen, kept in a cell of its own. There is no loop over the
    catalogue, so a cycle costs a few bytecodes a behavior and each change a few more,
    however many changed; a loop over every behavior, whenever any state changed, cost
    several times as much (``bench/bench_width.py``).
    """
    bind = _differ_binder(len(behaviors))
    return bind(*behaviors, *[behavior.state for behavior in behaviors])


@functools.lru_cache(maxsize=16)
def _differ_binder(size: int) -> Callable[..., Callable[[], list[StateChangeRecord]]]:
    """:func:`state_differ`'s code for a catalogue of ``size``, compiled once per size:
    compiling it takes about 40 ms for a thousand behaviors."""
    seen = [f"s{index}" for index in range(size)]
    lines = [
        f"def bind({', '.join([f'b{index}' for index in range(size)] + seen)}):",
        "    def changes():",
        f"        nonlocal {', '.join(seen)}" if size else "",
        "        found = []",
    ]
    for index in range(size):
        lines += [
            f"        if (now := b{index}.state) is not s{index} and now != s{index}:",
            f"            found.append(({index}, s{index}, now))",
            f"            s{index} = now",
        ]
    lines += ["        return found", "    return changes", ""]
    namespace: dict[str, Any] = {}
    exec("\n".join(lines), namespace)  # noqa: S102 - our own source, of names and indices only
    bind: Callable[..., Callable[[], list[StateChangeRecord]]] = namespace["bind"]
    return bind


class CycleExecutor:
    """Drives a system cycle by cycle and reports its behavior state changes."""

    def __init__(self, system: System, random: RandomSource) -> None:
        self.system = system
        catalogue = system.behaviors
        self.behavior_ids = list(catalogue)
        self._changes = state_differ(list(catalogue.values()))
        self._update: Update = system.update
        self.clock = SimulatedHeartbeat()
        self.context = Context(random)
        random.bind(self.context)

    def step(self, interval_ns: int, state: Any) -> list[StateChangeRecord]:
        """Run cycle t: advance time by HB_t, update from RS_t, return BS_t."""
        context = self.context
        context.cycle += 1
        context.dt_ns = interval_ns
        clock = self.clock  # SimulatedHeartbeat.advance, inline: the hot path
        context.time_ns = clock.now_ns = clock.now_ns + interval_ns
        context.actor = -1
        if context.outputs:
            context.outputs = {}
        self._update(state, context)
        return self._changes()

    def pause_next_update(self, pause: Pause) -> None:
        """Hand the next cycle's update to ``pause``, once: :meth:`step` advances the
        context to the cycle (``cycle``, ``time_ns``, ``dt_ns`` as the behaviors will see
        them), then calls ``pause(update, state, context)``, which must run the update.

        The replay debugger stops there, one call from the system's update; every other
        cycle runs as before, at no cost.
        """
        update = self._update

        def paused(state: Any, context: Context) -> None:
            self._update = update
            pause(update, state, context)

        self._update = paused
