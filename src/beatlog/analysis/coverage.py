"""Transition coverage of a suite: which behavior states and transitions its DTCs exercise.

DTCs protect what the recorded sessions exercised and nothing else. Per behavior, the
states reached and the (before → after) transitions taken, with their DTCs and cycles;
declared states (a ``states`` attribute: an Enum or a sequence) that no DTC reaches, and
states earlier runs saw (:mod:`beatlog.suite.coverage`), are listed as unreached. A
transition is a behavior's state at one heartbeat and at the next, as the log holds them:
2 → 3 → 1 within one heartbeat shows as 2 → 1. Behaviors are kept system by system (two
robots may each have an ``avoid``); a DTC's system is the ``module:factory`` it replays
against (:attr:`~beatlog.analysis.recorded.RecordedChanges.system`).
"""

from __future__ import annotations

import enum
import json
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from beatlog.model.behavior import System
from beatlog.replay.baseline import TracedStateChange

__all__ = [
    "BehaviorCoverage",
    "Seen",
    "SuiteCoverage",
    "cover_changes",
    "declared_states",
]


def _key(state: Any) -> str:
    """A state as it reads in reports and JSON keys (states compare as they encode: an
    Enum member as its value)."""
    return json.dumps(state, default=_plain, sort_keys=True)


def _plain(value: Any) -> Any:
    return value.value if isinstance(value, enum.Enum) else repr(value)


@dataclass
class Seen:
    """Where something was seen: the DTCs, and in how many cycles in all."""

    dtcs: set[str] = field(default_factory=set)
    cycles: int = 0

    def add(self, dtc: str, cycles: int) -> None:
        self.dtcs.add(dtc)
        self.cycles += cycles


@dataclass
class BehaviorCoverage:
    """One behavior's states and transitions across a suite."""

    behavior: str
    system: str
    """The system the behavior belongs to (see the module's docstring)."""
    states: dict[str, Seen] = field(default_factory=dict)
    """State (as JSON text) → the DTCs it was in and the cycles spent in it."""
    transitions: dict[tuple[str, str], Seen] = field(default_factory=dict)
    """(before, after) → the DTCs that took it and how many times (its cycles)."""
    declared: tuple[str, ...] = ()
    """The states the behavior declares, when it does."""
    states_before: dict[str, tuple[str, ...]] = field(default_factory=dict)
    """State → the DTCs that reached it, in earlier runs."""
    transitions_before: dict[tuple[str, str], tuple[str, ...]] = field(default_factory=dict)
    """(before, after) → the DTCs that took it, in earlier runs."""

    @property
    def unreached(self) -> tuple[str, ...]:
        """Declared states no DTC reached."""
        return tuple(state for state in self.declared if state not in self.states)

    @property
    def no_longer_reached(self) -> dict[str, tuple[str, ...]]:
        """States earlier runs saw (with the DTCs that reached them then) that no DTC
        reaches now and the behavior does not declare (those are :attr:`unreached`)."""
        return {
            state: dtcs
            for state, dtcs in self.states_before.items()
            if state not in self.states and state not in self.declared
        }

    @property
    def no_longer_taken(self) -> dict[tuple[str, str], tuple[str, ...]]:
        """Transitions earlier runs saw (with their DTCs then) that no DTC takes now."""
        return {
            edge: dtcs
            for edge, dtcs in self.transitions_before.items()
            if edge not in self.transitions
        }

    @property
    def dtcs(self) -> set[str]:
        """The DTCs in which this behavior changed state."""
        return set().union(*(seen.dtcs for seen in self.transitions.values()))


@dataclass
class SuiteCoverage:
    """Every behavior's coverage, system by system, each in the order first seen."""

    systems: dict[str, dict[str, BehaviorCoverage]] = field(default_factory=dict)
    """System → behavior name → its coverage."""
    dtcs: list[str] = field(default_factory=list)
    """The DTCs covered, by id."""
    labels: dict[str, str] = field(default_factory=dict)
    """How reports name the DTCs, by id (:attr:`beatlog.suite.spec.DtcSpec.label`); one
    not here, by its id."""

    def behavior(self, system: str, name: str) -> BehaviorCoverage:
        """The coverage of ``system``'s behavior ``name`` (created empty if the suite
        never saw it)."""
        behaviors = self.systems.setdefault(system, {})
        return behaviors.setdefault(name, BehaviorCoverage(name, system))

    @property
    def behaviors(self) -> list[BehaviorCoverage]:
        """Every behavior's coverage, system by system."""
        return [cover for behaviors in self.systems.values() for cover in behaviors.values()]

    def label(self, dtc: str) -> str:
        """How reports name the DTC of id ``dtc``."""
        return self.labels.get(dtc, dtc)

    def exercising(self, behavior: str) -> list[str]:
        """The DTCs in which a behavior named ``behavior`` changed state, whatever its
        system, in suite order."""
        found = [cover.dtcs for cover in self.behaviors if cover.behavior == behavior]
        names = set().union(*found)
        return [dtc for dtc in self.dtcs if dtc in names]

    def to_json(self) -> dict[str, Any]:
        """A plain structure for tools: the DTCs by id, and per system and behavior, its
        states, transitions and unreached states."""
        return {
            "dtcs": self.dtcs,
            "systems": {
                system: {name: _behavior_json(cover) for name, cover in behaviors.items()}
                for system, behaviors in self.systems.items()
            },
        }


def _behavior_json(cover: BehaviorCoverage) -> dict[str, Any]:
    return {
        "states": {
            state: {"dtcs": sorted(seen.dtcs), "cycles": seen.cycles}
            for state, seen in cover.states.items()
        },
        "transitions": [
            {"before": before, "after": after, "dtcs": sorted(seen.dtcs), "times": seen.cycles}
            for (before, after), seen in cover.transitions.items()
        ],
        "declared": list(cover.declared),
        "unreached": list(cover.unreached),
        "no_longer_reached": [
            {"state": state, "dtcs_before": list(dtcs)}
            for state, dtcs in cover.no_longer_reached.items()
        ],
        "no_longer_taken": [
            {"before": before, "after": after, "dtcs_before": list(dtcs)}
            for (before, after), dtcs in cover.no_longer_taken.items()
        ],
    }


def declared_states(system: System) -> dict[str, tuple[str, ...]]:
    """Each behavior's declared states (its ``states``: an Enum class or a sequence)."""
    declared: dict[str, tuple[str, ...]] = {}
    for name, behavior in system.behaviors.items():
        states = getattr(behavior, "states", None)
        if isinstance(states, type) and issubclass(states, enum.Enum):
            declared[name] = tuple(_key(member.value) for member in states)
        elif isinstance(states, Sequence) and not isinstance(states, str):
            declared[name] = tuple(_key(state) for state in states)
    return declared


def cover_changes(
    dtcs: Iterable[tuple[str, str, Sequence[TracedStateChange], int, System | None]],
) -> SuiteCoverage:
    """The coverage of DTCs given as (id, the name of their system, the state changes
    their log recorded, its cycles, a fresh system or None), as a log's
    :class:`~beatlog.analysis.recorded.RecordedChanges` hold them.

    The system, when given, tells each behavior's first state (a behavior that never
    changes still counts its cycles there) and its declared states."""
    suite = SuiteCoverage()
    for dtc, name, changes, cycles, system in dtcs:
        suite.dtcs.append(dtc)
        initial = {} if system is None else {n: b.state for n, b in system.behaviors.items()}
        by_behavior: dict[str, list[TracedStateChange]] = defaultdict(list)
        for traced in changes:
            by_behavior[traced.change.behavior].append(traced)
        for behavior in dict.fromkeys([*initial, *by_behavior]):
            own = by_behavior.get(behavior, [])
            cover = suite.behavior(name, behavior)
            state = initial[behavior] if behavior in initial else own[0].change.before
            since = 0
            for traced in own:
                change = traced.change
                cover.states.setdefault(_key(state), Seen()).add(dtc, traced.cycle - since)
                edge = (_key(change.before), _key(change.after))
                cover.transitions.setdefault(edge, Seen()).add(dtc, 1)
                state, since = change.after, traced.cycle
            cover.states.setdefault(_key(state), Seen()).add(dtc, cycles - since)
        for behavior, states in ({} if system is None else declared_states(system)).items():
            cover = suite.behavior(name, behavior)
            cover.declared = tuple(dict.fromkeys([*cover.declared, *states]))
    suite.dtcs = list(dict.fromkeys(suite.dtcs))
    return suite
