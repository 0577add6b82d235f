"""beatlog: record robot sessions and replay them as deterministic test cases (DTCs).

Record a session on the robot (heartbeat intervals, robot state, behavior state
changes, random numbers), replay it anywhere on a simulated clock, and fail exactly
when the behaviors no longer do what they did.

The public names are imported on first use: ``import beatlog`` stays light.
"""

from typing import TYPE_CHECKING

from beatlog.log._lazy import lazy_names

if TYPE_CHECKING:
    from beatlog._version import __version__ as __version__
    from beatlog.errors import BeatlogError as BeatlogError
    from beatlog.log import SessionLogReader as SessionLogReader
    from beatlog.model import Context as Context
    from beatlog.model import LiveHeartbeat as LiveHeartbeat
    from beatlog.model import PriorityArbiter as PriorityArbiter
    from beatlog.model import RobotState as RobotState
    from beatlog.model import SensorInbox as SensorInbox
    from beatlog.model import System as System
    from beatlog.model.inbox import Sample as Sample
    from beatlog.model.invariant import Cycle as Cycle
    from beatlog.model.invariant import Invariant as Invariant
    from beatlog.model.perception import Perception as Perception
    from beatlog.model.robot import Robot as Robot
    from beatlog.record import Recorder as Recorder
    from beatlog.replaying import Divergence as Divergence
    from beatlog.replaying import DivergenceKind as DivergenceKind
    from beatlog.replaying import ReplayResult as ReplayResult
    from beatlog.replaying import StateChange as StateChange
    from beatlog.suite.approved import replay as replay

__getattr__ = lazy_names(__name__)
