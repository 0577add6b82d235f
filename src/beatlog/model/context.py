"""The context handed to behaviors each cycle: time, dt, random numbers and outputs."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from beatlog.model.source import RandomSource

__all__ = ["Context", "Outputs"]

Outputs = dict[str, Any]
"""Values behaviors report to be checked each cycle, such as motor commands."""


class Context:
    """What a behavior may know beyond the robot state; the only source of time and chance.

    The engine updates one context in place each heartbeat. Its attributes:

    - ``random``: the only random source a behavior may draw from
      (:class:`~beatlog.model.random.RandomSource`: recorded live, replayed from RN_t);
    - ``cycle``: the heartbeat's index t, from 0;
    - ``time_ns`` and ``dt_ns``: robot time at the end of this cycle and HB_t, in ns
      (``time`` and ``dt`` in seconds);
    - ``outputs``: what the behaviors reported this cycle (:meth:`emit`);
    - ``actor``: the behavior currently stepping (an index into the system's
      catalogue, -1 for the system itself), so random draws and failures are
      attributed to it; arbiters set it.
    """

    __slots__ = ("actor", "cycle", "dt_ns", "outputs", "random", "time_ns")

    def __init__(self, random: RandomSource) -> None:
        self.random = random
        self.cycle = -1
        self.time_ns = 0
        self.dt_ns = 0
        self.actor = -1
        self.outputs: Outputs = {}

    @property
    def time(self) -> float:
        """Robot time in seconds since the session started (sum of heartbeat intervals)."""
        return self.time_ns / 1e9

    @property
    def dt(self) -> float:
        """Length of this cycle's heartbeat interval HB_t in seconds."""
        return self.dt_ns / 1e9

    def emit(self, name: str, value: Any) -> None:
        """Report an output (e.g. a motor command); outputs are recorded and checked."""
        self.outputs[name] = value
