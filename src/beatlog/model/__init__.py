"""The execution model, the same on the robot and on a PC.

Heartbeat clocks, the robot state, the sensor inbox, the behavior protocol with a
priority arbiter, the random source and the context handed to behaviors.
"""

from beatlog.model.behavior import (
    Behavior,
    BehaviorState,
    PlainBehavior,
    PriorityArbiter,
    System,
)
from beatlog.model.clock import DEFAULT_PERIOD_NS, LiveHeartbeat, SimulatedHeartbeat
from beatlog.model.context import Context, Outputs
from beatlog.model.inbox import Sample, SensorInbox
from beatlog.model.random import Draw, DrawKind, RandomSource, RecordingRandom
from beatlog.model.state import RobotState

__all__ = [
    "DEFAULT_PERIOD_NS",
    "Behavior",
    "BehaviorState",
    "Context",
    "Draw",
    "DrawKind",
    "LiveHeartbeat",
    "Outputs",
    "PlainBehavior",
    "PriorityArbiter",
    "RandomSource",
    "RecordingRandom",
    "RobotState",
    "Sample",
    "SensorInbox",
    "SimulatedHeartbeat",
    "System",
]
