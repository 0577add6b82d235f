"""beatlog: record robot sessions and replay them as deterministic test cases (DTCs).

Record a session on the robot (heartbeat intervals, robot state, behavior state
changes, random numbers), replay it anywhere on a simulated clock, and fail exactly
when the behaviors no longer do what they did.

The public names are imported on first use: ``import beatlog`` stays light.
"""

import importlib
from typing import TYPE_CHECKING

from beatlog._lazy import lazy_names
from beatlog._version import __version__
from beatlog.errors import BeatlogError

if TYPE_CHECKING:
    from beatlog.log import SessionLogReader
    from beatlog.model import (
        Context,
        LiveHeartbeat,
        PriorityArbiter,
        RobotState,
        SensorInbox,
        System,
    )
    from beatlog.model.inbox import Sample
    from beatlog.model.perception import Perception
    from beatlog.model.robot import Robot
    from beatlog.record import Recorder
    from beatlog.replay import Divergence, DivergenceKind, ReplayResult, StateChange
    from beatlog.suite.approved import replay

__all__ = [
    "BeatlogError",
    "Context",
    "Divergence",
    "DivergenceKind",
    "LiveHeartbeat",
    "Perception",
    "PriorityArbiter",
    "Recorder",
    "ReplayResult",
    "Robot",
    "RobotState",
    "Sample",
    "SensorInbox",
    "SessionLogReader",
    "StateChange",
    "System",
    "__version__",
    "replay",
]

__getattr__ = lazy_names(
    __name__,
    {
        "Context": "beatlog.model",
        "Divergence": "beatlog.replay",
        "DivergenceKind": "beatlog.replay",
        "LiveHeartbeat": "beatlog.model",
        "Perception": "beatlog.model.perception",
        "PriorityArbiter": "beatlog.model",
        "Recorder": "beatlog.record",
        "ReplayResult": "beatlog.replay",
        "Robot": "beatlog.model.robot",
        "RobotState": "beatlog.model",
        "Sample": "beatlog.model.inbox",
        "SensorInbox": "beatlog.model",
        "SessionLogReader": "beatlog.log",
        "StateChange": "beatlog.replay",
        "System": "beatlog.model",
        "replay": "beatlog.suite.approved",
    },
)

# The subpackage beatlog.replay shares its name with the function beatlog.replay, and
# importing the subpackage binds the name to it. Import it now (its own names are lazy,
# so it costs nothing) and unbind the name: it is __getattr__'s, which gives the function.
importlib.import_module("beatlog.replay")
del globals()["replay"]
