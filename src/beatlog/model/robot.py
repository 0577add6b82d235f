"""The robot side of a recording: sensors, perception and actuators around a system."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, runtime_checkable

import msgspec

from beatlog.model.behavior import System
from beatlog.model.context import Outputs
from beatlog.model.inbox import Sample, SensorInbox

__all__ = ["Robot"]


@runtime_checkable
class Robot(Protocol):
    """What the record loop needs beyond the behaviors: a real or simulated robot.

    Driver threads started by :meth:`start` push samples into :attr:`inbox`; at each
    heartbeat :meth:`perceive` folds them into the new robot state RS_t, the system
    updates, and :meth:`act` applies the outputs (e.g. motor commands).
    """

    @property
    def system(self) -> System:
        """The behavior software under test."""
        ...

    @property
    def inbox(self) -> SensorInbox:
        """Where the sensor drivers put their samples."""
        ...

    def start(self) -> None:
        """Start physics and sensor drivers."""
        ...

    def stop(self) -> None:
        """Stop everything :meth:`start` started."""
        ...

    def perceive(self, previous: Any | None, samples: Sequence[Sample]) -> msgspec.Struct:
        """The perception step: the new robot state from the last one and new samples."""
        ...

    def act(self, outputs: Outputs) -> None:
        """Apply one cycle's outputs to the actuators."""
        ...
