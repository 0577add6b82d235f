"""Record and replay a py_trees behaviour tree as a beatlog system.

:class:`TreeSystem` ticks the tree once per heartbeat with RS_t on the blackboard under
``robot_state``; its behaviors are the nodes, named by their paths of names from the
root (``Rover/Tasks/Dock``, a second sibling of one name ``…/Wait#2``), never by
py_trees' per-run uuids, each with its status as its state, and the blackboard keys
asked for (``blackboard/KEY``). A behaviour asks :func:`context` and :func:`random` for
robot time and random numbers, credited to it. py_trees' own timers and
``ProbabilisticBehaviour`` read the ``time`` and ``random`` modules: on import this
module gives those py_trees modules stand-ins that answer with robot time and
beatlog's random source while a :class:`TreeSystem` ticks in the calling thread, and
as the modules do otherwise. py_trees' blackboard is global to the process: building a
:class:`TreeSystem` clears it, so two trees must not be built and ticked in turns.
"""

from __future__ import annotations

import functools
import random as stdlib_random
import threading
import time as wall_clock
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

import msgspec

try:
    import py_trees
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError(
        "beatlog.adapters.py_trees needs py_trees: pip install 'beatlog[py-trees]'"
    ) from exc

from beatlog.model.behavior import Behavior, BehaviorState, CataloguedSystem
from beatlog.model.context import Context
from beatlog.model.random import RandomSource

__all__ = ["BLACKBOARD_PREFIX", "ROBOT_STATE_KEY", "TreeSystem", "context", "random"]

ROBOT_STATE_KEY = "robot_state"
"""The blackboard key that holds RS_t during a tick."""

BLACKBOARD_PREFIX = "blackboard/"
"""How watched blackboard keys are named in the catalogue: ``blackboard/KEY``."""

RS = TypeVar("RS", bound=msgspec.Struct)
Node = py_trees.behaviour.Behaviour


class _Tick(threading.local):
    """The tree ticking in this thread, and its context; None between ticks."""

    current: tuple[TreeSystem[Any], Context] | None = None


_TICK = _Tick()


class TreeSystem(CataloguedSystem[RS]):
    """A py_trees tree as a beatlog system: one tick per heartbeat.

    :param build: builds the tree and returns its root; called after the blackboard
        is cleared, on the robot and in replay alike, so it must not reach for
        hardware (any ``setup`` a behaviour needs is the builder's to call).
    :param robot_state: the robot state type written to the blackboard each tick.
    :param blackboard: keys whose values are observed as behaviors
        (``blackboard/KEY``); their values must encode in a log (names, numbers,
        flags, Enums, structs).

    Its catalogue holds every node in tree order (a parent before its children), then
    the watched keys.
    """

    def __init__(
        self,
        build: Callable[[], Node],
        *,
        robot_state: type[RS],
        blackboard: Sequence[str] = (),
    ) -> None:
        if isinstance(build, py_trees.behaviour.Behaviour):  # BehaviourTree(root)'s habit
            raise TypeError(
                f"TreeSystem takes the function that builds the tree, not the tree "
                f"{build.name!r} built: each replay builds its own (TreeSystem(tree, ...))"
            )
        py_trees.blackboard.Blackboard.clear()
        self._writer = py_trees.blackboard.Client(name="beatlog")
        self._writer.register_key(ROBOT_STATE_KEY, access=py_trees.common.Access.WRITE)
        self.root = build()
        catalogue: dict[str, Behavior] = {}
        self._actors: dict[Node, int] = {}
        for path, node in _paths(self.root, _escape(self.root.name)):
            actor = self._actors[node] = len(catalogue)
            for method in ("initialise", "update", "terminate"):
                setattr(node, method, _credited(getattr(node, method), actor))
            catalogue[path] = _Status(node)
        for key in blackboard:
            name = BLACKBOARD_PREFIX + key.lstrip("/")
            if name in catalogue:
                raise ValueError(f"{name!r} is both a tree node and a watched blackboard key")
            catalogue[name] = _BlackboardValue(key)
        super().__init__(robot_state, catalogue)

    def actor(self, node: Node) -> int:
        """The catalogue index of a node of this tree."""
        try:
            return self._actors[node]
        except KeyError:
            raise ValueError(f"{node.name!r} is not a node of this tree") from None

    def update(self, state: RS, context: Context) -> None:
        """Write RS_t to the blackboard and tick the tree once on robot time."""
        outer = _TICK.current
        _TICK.current = (self, context)
        try:
            self._writer.set(ROBOT_STATE_KEY, state)
            self.root.tick_once()
        finally:
            _TICK.current = outer


def context(node: Node) -> Context:
    """The context of the tick in progress (time, dt, random numbers, emit), with what
    is drawn or emitted credited to ``node``.

    :raises RuntimeError: no :class:`TreeSystem` is ticking in this thread.
    """
    current = _TICK.current
    if current is None:
        raise RuntimeError(f"{node.name!r} asked for beatlog's context outside a tree's tick")
    system, tick = current
    tick.actor = system.actor(node)
    return tick


def random(node: Node) -> RandomSource:
    """beatlog's random source for ``node`` during a tick; its draws are logged as
    the node's (``random(self).choice(waypoints)``)."""
    return context(node).random


@dataclass(frozen=True, slots=True)
class _Status:
    """A node as a catalogued behavior: its state is its status's name."""

    node: Node

    @property
    def state(self) -> BehaviorState:
        return str(self.node.status.value)


@dataclass(frozen=True, slots=True)
class _BlackboardValue:
    """A watched blackboard key as a catalogued behavior; None until it is set."""

    key: str

    @property
    def state(self) -> Any:
        try:
            value = py_trees.blackboard.Blackboard.get(self.key)
        except KeyError:
            return None
        return msgspec.to_builtins(value)  # a copy: a value changed in place still shows


def _paths(node: Node, path: str) -> Iterator[tuple[str, Node]]:
    """The node and its descendants in tree order, with their paths."""
    yield path, node
    seen: dict[str, int] = {}
    for child in node.children:
        name = _escape(child.name)
        seen[name] = count = seen.get(name, 0) + 1
        yield from _paths(child, f"{path}/{name}" if count == 1 else f"{path}/{name}#{count}")


def _escape(name: str) -> str:
    """A node name made safe to join into a path ('/' and '#' have meanings there)."""
    return name.replace("%", "%25").replace("/", "%2F").replace("#", "%23")


def _credited(method: Callable[..., Any], actor: int) -> Callable[..., Any]:
    """``method`` with ``context.actor`` set to the node's index while it runs in a tick."""

    @functools.wraps(method)
    def run(*args: Any) -> Any:
        current = _TICK.current
        if current is None:
            return method(*args)
        tick = current[1]
        outer, tick.actor = tick.actor, actor
        try:
            return method(*args)
        finally:
            tick.actor = outer

    return run


class _TreeTime:
    """The ``time`` module as py_trees' timers see it: ``time()`` and ``monotonic()``
    are robot time during a tick."""

    def __getattr__(self, name: str) -> Any:
        current = _TICK.current
        if current is None or name not in ("time", "monotonic"):
            return getattr(wall_clock, name)
        now = current[1].time
        return lambda: now


class _TreeRandom:
    """The ``random`` module as py_trees' behaviours see it: beatlog's random source
    during a tick (``random``, ``uniform``, ``gauss``, ``randint``, ``choice``,
    ``choices``), the global generator otherwise."""

    def __getattr__(self, name: str) -> Any:
        current = _TICK.current
        if current is None:
            return getattr(stdlib_random, name)
        source = current[1].random
        if name == "choices":
            return functools.partial(_choices, source)
        return getattr(source, name)


def _choices(
    source: RandomSource,
    population: Sequence[Any],
    weights: Sequence[float] | None = None,
    *,
    cum_weights: Sequence[float] | None = None,
    k: int = 1,
) -> list[Any]:
    """``random.choices`` on beatlog's random source: CPython's own, on the source's
    ``random()``, except that an unweighted pick is a ``choice`` of the source."""
    if weights is None and cum_weights is None:
        return [source.choice(population) for _ in range(k)]
    return stdlib_random.Random.choices(
        source,  # type: ignore[arg-type]  # it draws only by the source's random()
        population,
        weights,
        cum_weights=cum_weights,
        k=k,
    )


for _module, _name, _stand_in in (
    (py_trees.timers, "time", _TreeTime()),
    (py_trees.decorators, "time", _TreeTime()),
    (py_trees.behaviours, "random", _TreeRandom()),
):
    setattr(_module, _name, _stand_in)
