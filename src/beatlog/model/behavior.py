"""The behavior protocol any architecture can implement, and a built-in priority arbiter.

A system exposes a catalogue of behaviors, each with an observable ``state``, and an
``update`` that runs one cycle. After each update the engine diffs every state in
catalogue order; the changes are BS_t, the ordered list of (behavior, before, after).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Generic, Protocol, TypeVar, runtime_checkable

import msgspec

from beatlog.model.context import Context, Outputs

__all__ = [
    "Behavior",
    "BehaviorState",
    "CataloguedSystem",
    "PlainBehavior",
    "PriorityArbiter",
    "System",
]

BehaviorState = str | int | bool | None
"""What a behavior's observable state may be: a name, a number or a flag (Enums of str/int fit)."""

RS = TypeVar("RS", bound=msgspec.Struct)
RS_contra = TypeVar("RS_contra", bound=msgspec.Struct, contravariant=True)


@runtime_checkable
class Behavior(Protocol):
    """Anything whose state the engine can observe after each cycle."""

    @property
    def state(self) -> BehaviorState:
        """The current state, compared after every cycle."""
        ...


@runtime_checkable
class System(Protocol):
    """The behavior software under test: what record and replay drive, cycle by cycle.
    It may declare ``period_ns``, the heartbeat period its behaviors are written for: a
    log recorded at another period then replays with a note saying so."""

    @property
    def robot_state(self) -> type[msgspec.Struct]:
        """The robot state type RS this system reads."""
        ...

    @property
    def behaviors(self) -> Mapping[str, Behavior]:
        """The behavior catalogue: stable ids (names or paths) to behaviors, in a fixed order."""
        ...

    def update(self, state: Any, context: Context) -> None:
        """Update every behavior for one heartbeat from the robot state RS_t."""
        ...


class PlainBehavior(Protocol[RS_contra]):
    """A behavior for the priority arbiter: it steps and may ask for control."""

    @property
    def name(self) -> str:
        """The behavior's id in the catalogue."""
        ...

    @property
    def state(self) -> BehaviorState:
        """The current state, compared after every cycle."""
        ...

    def step(self, state: RS_contra, context: Context) -> Outputs | None:
        """Run one cycle; return the outputs it wants applied, or None to stay passive."""
        ...


class CataloguedSystem(Generic[RS]):
    """What a :class:`System` exposes, held once it is built: its robot state type, its
    catalogue of behaviors and, if given, its heartbeat period (a subclass defines
    ``update``)."""

    def __init__(
        self,
        robot_state: type[RS],
        catalogue: Mapping[str, Behavior],
        *,
        period_ns: int | None = None,
    ) -> None:
        self.robot_state = robot_state
        """The robot state type the behaviors read."""
        self.behaviors = catalogue
        """The behaviors in catalogue order, each by its name."""
        self.period_ns = period_ns
        """The heartbeat period the behaviors are written for, in ns; None: not declared."""


class PriorityArbiter(CataloguedSystem[RS]):
    """Subsumption-style arbitration: every behavior steps, the highest-priority one that
    asks for control wins, and its outputs are emitted.

    The arbiter is itself a behavior whose state is the name of the winner (``"idle"``
    when none asks), so a change of control is a state change in the log. Its
    catalogue holds the arbiter first, then its behaviors from highest to lowest priority.

    With ``per_output``, each output goes to the highest-priority behavior that proposes
    it, as subsumption arbitrates each actuator (a longitudinal and a lateral behavior
    each keep their own), and the state names each output's winner
    (``"acceleration: follow, steering: keep_lane"``). ``period_ns`` declares the
    heartbeat period the behaviors are written for.
    """

    def __init__(
        self,
        behaviors: Sequence[PlainBehavior[RS]],
        *,
        robot_state: type[RS],
        name: str = "arbiter",
        per_output: bool = False,
        period_ns: int | None = None,
    ) -> None:
        self.name = name
        self.state: BehaviorState = "idle"
        self.per_output = per_output
        self._children = tuple(behaviors)
        catalogue: dict[str, Behavior] = {name: self}
        for behavior in self._children:
            if behavior.name in catalogue:
                raise ValueError(f"two behaviors are named {behavior.name!r}")
            catalogue[behavior.name] = behavior
        super().__init__(robot_state, catalogue, period_ns=period_ns)

    def update(self, state: RS, context: Context) -> None:
        """Step every behavior in priority order and emit the winner's outputs (each
        output's winner's, ``per_output``)."""
        if self.per_output:
            self._update_per_output(state, context)
            return
        winner: PlainBehavior[RS] | None = None
        command: Outputs | None = None
        for actor, behavior in enumerate(self._children, start=1):
            context.actor = actor
            proposal = behavior.step(state, context)
            if winner is None and proposal is not None:
                winner, command = behavior, _outputs(behavior, proposal)
        context.actor = 0
        self.state = "idle" if winner is None else winner.name
        if command:
            context.outputs.update(command)

    def _update_per_output(self, state: RS, context: Context) -> None:
        command: Outputs = {}
        winners: dict[str, str] = {}
        for actor, behavior in enumerate(self._children, start=1):
            context.actor = actor
            proposal = behavior.step(state, context)
            for output, value in ({} if proposal is None else _outputs(behavior, proposal)).items():
                if output not in command:
                    command[output] = value
                    winners[output] = behavior.name
        context.actor = 0
        owned = [f"{output}: {winners[output]}" for output in sorted(winners)]
        self.state = ", ".join(owned) if owned else "idle"
        context.outputs.update(command)


def _outputs(behavior: PlainBehavior[Any], proposal: object) -> Outputs:
    """What a behavior's step asked for, which must be a dict of outputs (None, asking for
    nothing, is sorted out before): else a TypeError naming the behavior, for a step that
    returns a bare value such as ``1.0`` (which ``0.0`` would otherwise silently win with)."""
    if not isinstance(proposal, dict):
        raise TypeError(
            f"behavior {behavior.name!r}: step returned {proposal!r}; "
            "it returns the outputs it asks for, a dict such as {'turn': 1.0}, or None"
        )
    return proposal
