"""The thermostat as its owner wrote it, with the lines recording it marked ``# beatlog``.

A heater behavior with hysteresis and a timed boost under a priority arbiter, and the
thermostat's own ``while`` loop: read the sensor, let the behaviors decide through
:meth:`Recorder.beat <beatlog.record.recorder.Recorder.beat>`, switch the heater, wait.
"""

from __future__ import annotations

from pathlib import Path

from beatlog import Context, PriorityArbiter, Recorder, RobotState  # beatlog
from beatlog_examples.thermostat.room import Room

__all__ = [
    "Boost",
    "Climate",
    "Heater",
    "changed_system",
    "record",
    "system",
    "thermostat_loop",
]

PERIOD_S = 10.0
"""The thermostat reads its sensor every 10 s."""
SETPOINT = 21.0
BAND = 0.5
"""The heater turns on below the setpoint minus this, and off above it plus this (°C)."""
HEATER_POWER = 0.6
BOOST_BELOW = 2.0
"""Boost heats at full power when the room is this far below its setpoint (°C)."""


class Climate(RobotState, kw_only=True):  # beatlog: the robot state RS_t
    """What the thermostat knows: the room's temperature and the setpoint, in °C."""

    temperature: float
    setpoint: float = SETPOINT


class Heater:
    """Bang-bang with hysteresis: on below the setpoint's band, off above it."""

    name = "heater"  # beatlog: the behavior's name in the log

    def __init__(self, band: float = BAND) -> None:
        self.state = "off"
        self.band = band

    def step(self, climate: Climate, ctx: Context) -> dict[str, float]:
        if climate.temperature < climate.setpoint - self.band:
            self.state = "on"
        elif climate.temperature > climate.setpoint + self.band:
            self.state = "off"
        return {"heater": HEATER_POWER if self.state == "on" else 0.0}


class Boost:
    """A cold room gets full power for 10 to 20 minutes, drawn at random; then boost
    rests until the room has reached its setpoint."""

    name = "boost"  # beatlog: the behavior's name in the log

    def __init__(self) -> None:
        self.state = "idle"
        self._until_s = 0.0

    def step(self, climate: Climate, ctx: Context) -> dict[str, float] | None:
        if self.state == "idle" and climate.temperature < climate.setpoint - BOOST_BELOW:
            self.state = "boosting"
            self._until_s = ctx.time + ctx.random.uniform(600.0, 1200.0)  # beatlog: ctx
        elif self.state == "boosting" and ctx.time >= self._until_s:  # beatlog: ctx
            self.state = "resting"
        elif self.state == "resting" and climate.temperature >= climate.setpoint:
            self.state = "idle"
        return {"heater": 1.0} if self.state == "boosting" else None


def system() -> PriorityArbiter[Climate]:  # beatlog: the system under test
    return PriorityArbiter([Boost(), Heater()], robot_state=Climate)  # beatlog


def changed_system() -> PriorityArbiter[Climate]:
    """A planted bug: the band's sign slipped, so the heater turns on inside the band."""
    return PriorityArbiter([Boost(), Heater(band=-BAND)], robot_state=Climate)


def thermostat_loop(recorder: Recorder, room: Room, *, cycles: int | None = None) -> None:
    """The thermostat's own main loop: read, decide, switch, wait (for ever, or
    ``cycles`` times)."""
    while cycles is None or recorder.cycles < cycles:
        climate = Climate(temperature=room.read_temperature())
        power = recorder.beat(climate)["heater"]  # beatlog: the behaviors decide
        room.switch_heater(power)
        room.wait(PERIOD_S)


def record(path: Path, *, hours: float = 2.0, seed: int | None = None) -> Path:
    """Record ``hours`` of the thermostat in the simulated room into ``path``."""
    room = Room()
    with Recorder(  # beatlog
        path,
        system(),
        system_ref="beatlog_examples.thermostat:system",
        period_ns=int(PERIOD_S * 1e9),
        seed=seed,
        clock=room.clock_ns,
    ) as recorder:
        thermostat_loop(recorder, room, cycles=round(hours * 3600 / PERIOD_S))
    return path
