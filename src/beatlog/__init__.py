"""beatlog: record robot sessions and replay them as deterministic test cases (DTCs).

Record a session on the robot (heartbeat intervals, robot state, behavior state
changes, random numbers), replay it anywhere on a simulated clock, and fail exactly
when the behaviors no longer do what they did.

The public names are imported on first use: ``import beatlog`` stays light.
``beatlog.replay`` is the replay subpackage, and called, it replays a log:
``beatlog.replay(log, system)``.
"""

import importlib
from types import ModuleType
from typing import TYPE_CHECKING, Any

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
    from beatlog.replay import Divergence as Divergence
    from beatlog.replay import DivergenceKind as DivergenceKind
    from beatlog.replay import ReplayResult as ReplayResult
    from beatlog.replay import StateChange as StateChange
    from beatlog.suite.approved import replay as replay

__getattr__ = lazy_names(__name__)


class _Replay(ModuleType):
    """The class of the subpackage :mod:`beatlog.replay`, which makes it callable as
    :func:`beatlog.suite.approved.replay`: one name, ``beatlog.replay``, for both."""

    def __call__(self, *args: Any, **options: Any) -> "ReplayResult":
        """Replay a log: the arguments and result of :func:`beatlog.suite.approved.replay`
        (type checkers read ``beatlog.replay`` as that function)."""
        from beatlog.suite.approved import replay  # noqa: PLC0415 - import stays light

        return replay(*args, **options)


importlib.import_module(f"{__name__}.replay").__class__ = _Replay
