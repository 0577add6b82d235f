"""A room thermostat whose own loop beatlog records from inside: no robot adapter.

The thermostat is written as its owner wrote it before beatlog: a heater behavior with
hysteresis, a timed boost, and a ``while`` loop that reads the sensor and switches the
heater. Recording it takes the lines marked ``# beatlog``: the behaviors take time and
chance from the context, the loop's decision comes from :meth:`Recorder.beat
<beatlog.record.recorder.Recorder.beat>` (which measures each heartbeat), and a factory
builds the system for replay::

    python -m beatlog_examples.thermostat -o thermostat.beatlog --hours 2
    beatlog replay thermostat.beatlog --system beatlog_examples.thermostat:system
    beatlog replay thermostat.beatlog --system beatlog_examples.thermostat:changed_system

The room (:mod:`~beatlog_examples.thermostat.room`) is simulated, with a clock of its
own, so two hours record in a moment; on a real thermostat the loop sleeps and the
recorder's clock is the monotonic clock.
``changed_system`` is a planted bug: the hysteresis band's sign slipped.
"""

from beatlog_examples.thermostat.controller import (
    Boost,
    Climate,
    Heater,
    changed_system,
    record,
    system,
    thermostat_loop,
)
from beatlog_examples.thermostat.room import Room

__all__ = [
    "Boost",
    "Climate",
    "Heater",
    "Room",
    "changed_system",
    "record",
    "system",
    "thermostat_loop",
]
