"""beatlog: record robot sessions and replay them as deterministic test cases (DTCs).

Record a session on the robot (heartbeat intervals, robot state, behavior state
changes, random numbers), replay it anywhere on a simulated clock, and fail exactly
when the behaviors no longer do what they did.
"""

from beatlog._version import __version__
from beatlog.errors import BeatlogError
from beatlog.log import SessionLogReader
from beatlog.model import (
    Context,
    LiveHeartbeat,
    PriorityArbiter,
    RobotState,
    SensorInbox,
    System,
)
from beatlog.model.robot import Robot
from beatlog.record import Recorder
from beatlog.replay import (
    Divergence,
    DivergenceKind,
    ReplayResult,
    StateChange,
    replay,
)

__all__ = [
    "BeatlogError",
    "Context",
    "Divergence",
    "DivergenceKind",
    "LiveHeartbeat",
    "PriorityArbiter",
    "Recorder",
    "ReplayResult",
    "Robot",
    "RobotState",
    "SensorInbox",
    "SessionLogReader",
    "StateChange",
    "System",
    "__version__",
    "replay",
]
