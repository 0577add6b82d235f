"""Invariants checked in every cycle a replay steps (or a recorder records), each handed
a :class:`~beatlog.model.invariant.Cycle`: RS_t as the behaviors saw it, every
behavior's state after the update, BS_t, the outputs and the draws. Only cycles whose
update completed are checked; one that did not is a divergence of its own.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from types import MappingProxyType
from typing import Any, NamedTuple

from beatlog.log.format import Draw, LoggedStateChange
from beatlog.model.behavior import System
from beatlog.model.invariant import Cycle, Invariant
from beatlog.project.usercode import load_invariant, user_traceback
from beatlog.replay.compare import state_fields
from beatlog.replay.outcome import CycleOutcome, random_draws
from beatlog.replay.verdict import Divergence, DivergenceKind, StateChange

__all__ = ["InvariantChecker", "Violation"]


class Violation(NamedTuple):
    """An invariant that did not hold in a cycle, or whose own code raised."""

    invariant: str
    cycle: Cycle
    message: str
    """Why: the assertion's message, or what the invariant's code raised."""
    failure: BaseException | None = None
    """What the invariant's own code raised (not an ``AssertionError``), if it did."""

    def __str__(self) -> str:
        return f"cycle {self.cycle.cycle}, t = {self.cycle.time:.3f} s: {self.message}"


class InvariantChecker:
    """Checks ``invariants`` in each cycle of ``system``: for the verdict's judge, which
    checks each cycle with it so that the earliest failure is the verdict, and for a
    recorder.

    Each invariant is a callable, a class (instantiated here, afresh for each checker,
    so that one that looks across cycles starts clean) or a ``module:attribute``
    reference to either, imported as a spec's ``system`` is.

    :raises beatlog.errors.SystemLoadError: a reference does not import, or names
        something that is not callable, or a class that cannot be built.
    """

    def __init__(self, invariants: Iterable[Invariant | type | str], system: System) -> None:
        built = [load_invariant(item) if isinstance(item, str) else item for item in invariants]
        self.invariants: list[tuple[str, Invariant]] = []
        for item in built:
            name = getattr(item, "__name__", None)  # a function's or a class's name
            name = name if isinstance(name, str) else type(item).__name__
            self.invariants.append((name, item() if isinstance(item, type) else item))
        self._behaviors = system.behaviors
        self._names = list(self._behaviors)

    def check(self, outcome: CycleOutcome) -> Divergence | None:
        """The first invariant that does not hold in a replayed cycle, as a divergence;
        None where all hold, or the update did not complete."""
        if outcome.changes is None or outcome.failure is not None:
            return None
        cycle = self.cycle(
            outcome.cycle,
            time_ns=outcome.time_ns,
            dt_ns=outcome.record.heartbeat_ns,
            state=outcome.state,
            changes=outcome.changes,
            outputs=outcome.outputs,
            draws=outcome.drawn,
        )
        violations = self.violated(cycle, first=True)
        return divergence(violations[0]) if violations else None

    def cycle(
        self,
        number: int,
        *,
        time_ns: int,
        dt_ns: int,
        state: Any,
        changes: Sequence[LoggedStateChange],
        outputs: dict[str, Any],
        draws: Sequence[Draw],
    ) -> Cycle:
        """A cycle as the invariants see it, the behaviors' states read now."""
        names = self._names
        return Cycle(
            number,
            time_ns,
            dt_ns,
            state,
            MappingProxyType({name: b.state for name, b in self._behaviors.items()}),
            tuple(StateChange(names[index], before, after) for index, before, after in changes),
            MappingProxyType(outputs),
            tuple(random_draws(draws, names)),
        )

    def violated(self, cycle: Cycle, *, first: bool = False) -> list[Violation]:
        """The invariants that do not hold in ``cycle``, in order (only the first, if
        ``first``): each raised ``AssertionError``, returned a false value other than
        None, or raised anything else (its own failure)."""
        found: list[Violation] = []
        for name, invariant in self.invariants:
            try:
                held = invariant(cycle)
            except AssertionError as exc:
                message = " ".join(str(exc).split()) or "its assertion failed"
                found.append(Violation(name, cycle, f"invariant {name} does not hold: {message}"))
            except (Exception, SystemExit) as exc:  # the invariant's own code failing
                what = " ".join(str(exc).split())
                message = f"invariant {name} raised {type(exc).__name__}" + (
                    f": {what}" if what else ""
                )
                found.append(Violation(name, cycle, message, exc))
            else:
                if held is None or held:
                    continue
                found.append(
                    Violation(name, cycle, f"invariant {name} does not hold: it returned {held!r}")
                )
            if first:
                break
        return found


def divergence(violation: Violation) -> Divergence:
    """A violation as the verdict reports it: the invariant, its message, and the values
    it saw (robot state, behavior states, state changes, outputs and draws)."""
    cycle = violation.cycle
    failure = violation.failure
    return Divergence(
        kind=DivergenceKind.INVARIANT,
        cycle=cycle.cycle,
        time_ns=cycle.time_ns,
        message=violation.message,
        actual=cycle.changes,
        actual_outputs=dict(cycle.outputs),
        robot_state=state_fields(cycle.robot_state),
        random_drawn=cycle.draws,
        traceback=None if failure is None else user_traceback(failure),
        invariant=violation.invariant,
        states=dict(cycle.states),
    )
