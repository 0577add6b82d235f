"""The rover's world: a walled arena with round obstacles and unicycle kinematics.

This is the environment, not the software under test: it may use its own noise and,
when live, the wall clock. Nothing here is replayed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = ["ARENA_SIZE", "MAX_RANGE", "RANGE_ANGLES", "World"]

ARENA_SIZE = 6.0
MAX_RANGE = 3.0
RANGE_ANGLES = (math.radians(35.0), 0.0, math.radians(-35.0))
"""Left, front and right range sensors, relative to the heading."""
RADIUS = 0.15


@dataclass
class World:
    """Arena walls at 0 and ``ARENA_SIZE`` on both axes, obstacles as (x, y, radius)."""

    x: float = 1.0
    y: float = 3.0
    heading: float = 0.0
    speed: float = 0.0
    turn_rate: float = 0.0
    bumped: bool = False
    obstacles: list[tuple[float, float, float]] = field(
        default_factory=lambda: [
            (2.4, 3.05, 0.4),
            (4.6, 1.4, 0.35),
            (4.2, 4.6, 0.45),
            (1.5, 1.4, 0.04),
            (3.9, 3.1, 0.04),
            (2.8, 5.0, 0.04),
            (1.2, 4.6, 0.04),
        ]
    )

    def command(self, speed: float, turn_rate: float) -> None:
        """Set the wheel command: forward speed (m/s) and turn rate (rad/s)."""
        self.speed = speed
        self.turn_rate = turn_rate

    def advance(self, dt: float) -> None:
        """Move the rover for ``dt`` seconds; a collision stops it and presses the bumper."""
        heading = self.heading + self.turn_rate * dt
        x = self.x + self.speed * math.cos(heading) * dt
        y = self.y + self.speed * math.sin(heading) * dt
        self.heading = math.remainder(heading, math.tau)
        if self._collides(x, y):
            self.bumped = True
            return
        self.bumped = False
        self.x, self.y = x, y

    def ranges(self) -> tuple[float, float, float]:
        """Distances from the rover's rim to the nearest surface along each range sensor."""
        return tuple(  # type: ignore[return-value]
            max(0.0, self._ray(self.heading + angle) - RADIUS) for angle in RANGE_ANGLES
        )

    def _collides(self, x: float, y: float) -> bool:
        if not (RADIUS <= x <= ARENA_SIZE - RADIUS and RADIUS <= y <= ARENA_SIZE - RADIUS):
            return True
        return any(math.hypot(x - ox, y - oy) < r + RADIUS for ox, oy, r in self.obstacles)

    def _ray(self, angle: float) -> float:
        dx, dy = math.cos(angle), math.sin(angle)
        best = MAX_RANGE + RADIUS
        for d, position, limit in ((dx, self.x, ARENA_SIZE), (dy, self.y, ARENA_SIZE)):
            if d > 1e-9:
                best = min(best, (limit - position) / d)
            elif d < -1e-9:
                best = min(best, -position / d)
        for ox, oy, r in self.obstacles:
            fx, fy = ox - self.x, oy - self.y
            along = fx * dx + fy * dy
            if along <= 0:
                continue
            miss2 = fx * fx + fy * fy - along * along
            if miss2 < r * r:
                best = min(best, along - math.sqrt(r * r - miss2))
        return min(best, MAX_RANGE + RADIUS)
