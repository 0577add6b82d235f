"""The sensor inbox: driver threads push samples at their own rates between heartbeats.

Samples wait in the inbox until the next heartbeat, when the perception step folds
them into the robot state, as the paper's robot state pattern asks.
"""

from __future__ import annotations

import threading
import time
from typing import Any, NamedTuple

__all__ = ["Sample", "SensorInbox"]


class Sample(NamedTuple):
    """One reading from one sensor, stamped with the driver's monotonic time in ns."""

    sensor: str
    """The sensor's name, as the driver pushed it (``"sonar"``, ``"/imu"``)."""
    stamp_ns: int
    """When the driver read it: its monotonic clock in ns (a bag's receive time)."""
    value: Any
    """The reading: any value msgpack holds (numbers, strings, lists, maps)."""


class SensorInbox:
    """A thread-safe queue of samples, emptied once per heartbeat."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._samples: list[Sample] = []

    def push(self, sensor: str, value: Any, *, stamp_ns: int | None = None) -> None:
        """Add a sample; called from any driver thread."""
        sample = Sample(sensor, time.monotonic_ns() if stamp_ns is None else stamp_ns, value)
        with self._lock:
            self._samples.append(sample)

    def drain(self) -> list[Sample]:
        """Take every sample collected since the last drain, oldest first."""
        with self._lock:
            samples, self._samples = self._samples, []
        return samples
