"""The thermostat's hardware, simulated: a room, its heater, its sensor and its clock."""

from __future__ import annotations

import random

__all__ = ["Room"]


class Room:
    """The thermostat's hardware, simulated: a room that loses heat to the outside (and
    more while its window is open), a heater, a noisy sensor, and a clock."""

    LOSS_PER_S = 1 / 3000
    """The share of the difference to the outside lost each second."""
    GAIN_PER_S = 0.011
    """How fast the heater warms the room at full power (°C/s)."""

    def __init__(
        self,
        *,
        temperature: float = 15.0,
        outside: float = 5.0,
        window_open_s: tuple[float, float] = (3600.0, 3900.0),
        seed: int = 0,
    ) -> None:
        self.temperature = temperature
        self.outside = outside
        self.window_open_s = window_open_s
        self.power = 0.0
        self.now_ns = 0
        self._noise = random.Random(seed)  # noqa: S311 - the sensor's own noise

    def read_temperature(self) -> float:
        """The sensor: the temperature to a hundredth of a degree, with some noise."""
        return round(self.temperature + self._noise.gauss(0.0, 0.05), 2)

    def switch_heater(self, power: float) -> None:
        self.power = power

    def clock_ns(self) -> int:
        """The room's time, in ns."""
        return self.now_ns

    def wait(self, seconds: float) -> None:
        """Let ``seconds`` pass in the room, a second at a time."""
        for _ in range(round(seconds)):
            opened, closed = self.window_open_s
            window = 4.0 if opened <= self.now_ns / 1e9 < closed else 1.0
            loss = window * self.LOSS_PER_S * (self.temperature - self.outside)
            self.temperature += self.GAIN_PER_S * self.power - loss
            self.now_ns += 1_000_000_000
