"""A patrol robot's behaviour tree in py_trees, recorded and replayed by beatlog.

::

    Rover                       Parallel: sense and act every tick
    ├── Sense                   Sequence
    │   └── Path                writes path_clear to the blackboard
    └── Tasks                   Selector: charging first
        ├── Charge              Sequence with memory
        │   ├── Battery low?    robot_state.battery below the threshold
        │   ├── Dock in time    Timeout
        │   │   └── Dock        drive to the dock until docked
        │   └── Charging        until the battery is full
        └── Patrol              Sequence with memory
            ├── Pick waypoint   a random waypoint, onto the blackboard
            ├── Go              Sequence: re-checks the path every tick
            │   ├── Wait for path   FailureIsRunning
            │   │   └── Path clear?
            │   └── Drive       distance left shrinks by speed × dt
            ├── Look around     FailureIsSuccess
            │   └── Sniff       py_trees' ProbabilisticBehaviour
            └── Pause           py_trees' Timer

Time (``Pause``, ``Dock in time``, ``Drive``) and chance (``Pick waypoint``,
``Sniff``) come from beatlog during a tick, so the same tree records on the robot
and replays on a PC. :data:`CHANGES` are deliberate bugs that the DTCs catch.
"""

from __future__ import annotations

import operator
from dataclasses import dataclass

import py_trees
from py_trees.common import ComparisonExpression, Status

from beatlog import RobotState
from beatlog.adapters.py_trees import TreeSystem, context, random

__all__ = ["CHANGES", "WAYPOINTS", "PatrolState", "Tuning", "changed_system", "system", "tree"]

WAYPOINTS = {"hall": 6.0, "lab": 9.0, "kitchen": 4.5}
"""Where the rover patrols, with the distance to drive there in metres."""


class PatrolState(RobotState, kw_only=True):
    """The rover's robot state: battery, the range ahead and the dock contact."""

    battery: float = 1.0
    """Charge from 0 to 1."""
    obstacle: float = 5.0
    """Range to the nearest obstacle ahead in metres."""
    docked: bool = False
    """On the charging dock."""


@dataclass(frozen=True)
class Tuning:
    """The tree's parameters; :data:`CHANGES` alter one each."""

    low_battery: float = 0.25
    full_battery: float = 0.9
    clearance_m: float = 0.6
    speed_m_s: float = 1.5
    dock_timeout_s: float = 8.0
    pause_s: float = 1.0
    charge_first: bool = True
    wait_for_path: type[py_trees.decorators.Decorator] = py_trees.decorators.FailureIsRunning


class SensePath(py_trees.behaviour.Behaviour):
    """Writes whether the path ahead is clear to the blackboard."""

    def __init__(self, clearance_m: float) -> None:
        super().__init__("Path")
        self.clearance_m = clearance_m
        self.bb = self.attach_blackboard_client()
        self.bb.register_key("robot_state", access=py_trees.common.Access.READ)
        self.bb.register_key("path_clear", access=py_trees.common.Access.WRITE)

    def update(self) -> Status:
        self.bb.path_clear = self.bb.robot_state.obstacle > self.clearance_m
        return Status.SUCCESS


class PickWaypoint(py_trees.behaviour.Behaviour):
    """Chooses the next waypoint at random and the distance left to it."""

    def __init__(self) -> None:
        super().__init__("Pick waypoint")
        self.bb = self.attach_blackboard_client()
        self.bb.register_key("waypoint", access=py_trees.common.Access.WRITE)
        self.bb.register_key("remaining_m", access=py_trees.common.Access.WRITE)

    def update(self) -> Status:
        self.bb.waypoint = random(self).choice(sorted(WAYPOINTS))
        self.bb.remaining_m = WAYPOINTS[self.bb.waypoint]
        return Status.SUCCESS


class Drive(py_trees.behaviour.Behaviour):
    """Drives to the waypoint: RUNNING until the distance left is covered."""

    def __init__(self, speed_m_s: float) -> None:
        super().__init__("Drive")
        self.speed_m_s = speed_m_s
        self.bb = self.attach_blackboard_client()
        self.bb.register_key("waypoint", access=py_trees.common.Access.READ)
        self.bb.register_key("remaining_m", access=py_trees.common.Access.WRITE)

    def update(self) -> Status:
        tick = context(self)
        self.bb.remaining_m -= self.speed_m_s * tick.dt
        if self.bb.remaining_m <= 0.0:
            return Status.SUCCESS
        tick.emit("drive_to", self.bb.waypoint)
        return Status.RUNNING


class Dock(py_trees.behaviour.Behaviour):
    """Drives onto the dock: RUNNING until the dock contact closes."""

    def __init__(self) -> None:
        super().__init__("Dock")
        self.bb = self.attach_blackboard_client()
        self.bb.register_key("robot_state", access=py_trees.common.Access.READ)

    def update(self) -> Status:
        if self.bb.robot_state.docked:
            return Status.SUCCESS
        context(self).emit("drive_to", "dock")
        return Status.RUNNING


class Charging(py_trees.behaviour.Behaviour):
    """Charges on the dock until the battery is full; fails off the dock."""

    def __init__(self, full_battery: float) -> None:
        super().__init__("Charging")
        self.full_battery = full_battery
        self.bb = self.attach_blackboard_client()
        self.bb.register_key("robot_state", access=py_trees.common.Access.READ)

    def update(self) -> Status:
        state = self.bb.robot_state
        if not state.docked:
            return Status.FAILURE
        if state.battery >= self.full_battery:
            return Status.SUCCESS
        context(self).emit("charge", True)
        return Status.RUNNING


def tree(tuning: Tuning = Tuning()) -> py_trees.behaviour.Behaviour:
    """Build the patrol tree (see the module docstring for its shape)."""
    battery_low = ComparisonExpression("robot_state.battery", tuning.low_battery, operator.lt)
    path_clear = ComparisonExpression("path_clear", True, operator.eq)
    charge = py_trees.composites.Sequence(
        "Charge",
        memory=True,
        children=[
            py_trees.behaviours.CheckBlackboardVariableValue("Battery low?", battery_low),
            py_trees.decorators.Timeout("Dock in time", Dock(), duration=tuning.dock_timeout_s),
            Charging(tuning.full_battery),
        ],
    )
    go = py_trees.composites.Sequence(
        "Go",
        memory=False,
        children=[
            tuning.wait_for_path(
                "Wait for path",
                py_trees.behaviours.CheckBlackboardVariableValue("Path clear?", path_clear),
            ),
            Drive(tuning.speed_m_s),
        ],
    )
    sniff = py_trees.behaviours.ProbabilisticBehaviour("Sniff", weights=[0.5, 0.3, 0.2])
    patrol = py_trees.composites.Sequence(
        "Patrol",
        memory=True,
        children=[
            PickWaypoint(),
            go,
            py_trees.decorators.FailureIsSuccess("Look around", sniff),
            py_trees.timers.Timer("Pause", duration=tuning.pause_s),
        ],
    )
    tasks = [charge, patrol] if tuning.charge_first else [patrol, charge]
    return py_trees.composites.Parallel(
        "Rover",
        policy=py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=False),
        children=[
            py_trees.composites.Sequence(
                "Sense", memory=False, children=[SensePath(tuning.clearance_m)]
            ),
            py_trees.composites.Selector("Tasks", memory=False, children=tasks),
        ],
    )


def system(tuning: Tuning = Tuning()) -> TreeSystem[PatrolState]:
    """The patrol tree as a beatlog system, watching its waypoint and path on the blackboard."""
    return TreeSystem(
        lambda: tree(tuning), robot_state=PatrolState, blackboard=("waypoint", "path_clear")
    )


CHANGES: dict[str, Tuning] = {
    "selector reordered": Tuning(charge_first=False),
    "threshold changed": Tuning(low_battery=0.2),
    "decorator swapped": Tuning(wait_for_path=py_trees.decorators.FailureIsSuccess),
}
"""Realistic bugs, each a one-line change to the tree."""


def changed_system(change: str = "threshold changed") -> TreeSystem[PatrolState]:
    """The system with one deliberate bug from :data:`CHANGES`."""
    return system(CHANGES[change])
