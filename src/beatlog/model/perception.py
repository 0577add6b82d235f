"""The perception step: how raw sensor samples become the robot state RS_t.

On the robot, perception folds the samples collected since the last heartbeat into
the new robot state. When a session was recorded with its samples, replay can run the
same step again (sensor-level replay), so a changed perception is caught by a DTC
without re-recording on the robot. A perception must be a pure function of the
previous state and the samples: no clock, no randomness, no hidden state.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

from beatlog.model.inbox import Sample

__all__ = ["Perception", "PerceptionTypeError", "perception_problem"]


class Perception(Protocol):
    """Builds RS_t from RS_t-1 (None before the first cycle) and the cycle's samples;
    replayed sample values come back as msgpack decodes them (tuples and numpy values as
    plain lists and numbers)."""

    def __call__(self, previous: Any | None, samples: Sequence[Sample], /) -> Any: ...


class PerceptionTypeError(TypeError):
    """A perception step returned something other than the system's robot state."""

    def __init__(self, rebuilt: object, robot_state: type[Any]) -> None:
        name = type(rebuilt).__name__
        kind = "None" if rebuilt is None else f"{'an' if name[0] in 'AEIOUaeiou' else 'a'} {name}"
        super().__init__(f"returned {kind}, not a {robot_state.__name__}")


def perception_problem(problem: BaseException) -> str:
    """What went wrong in the perception step, for reports: ``perception returned a
    dict, not a Probe`` or ``perception raised ValueError: no range sensor``."""
    if isinstance(problem, PerceptionTypeError):
        return f"perception {problem}"
    return f"perception raised {type(problem).__name__}: {problem}"
