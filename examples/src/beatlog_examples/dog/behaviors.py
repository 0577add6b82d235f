"""The dog's robot state and its twelve behaviors, under a priority arbiter, like the AIBO's.

Highest priority first: get_up (the accelerometer says it fell), remote (a person
drives it from another process), escape (bumped its nose or stuck), the three touch
responses chin, head_pat and back_touch, recharge (low battery: find the charging pad
and lie on it), sleep (bored: lie down and doze), avoid, wall_follow and wander. The
emotion model never takes control: it keeps happiness and boredom, which fluctuate at
random, and reports them as outputs, which the robot feeds back into the robot state.

Behaviors use only the robot state and the context: time and randomness come from
beatlog, so every session replays exactly. Nothing here imports MuJoCo.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from dataclasses import dataclass

from beatlog.model.behavior import BehaviorState, PriorityArbiter
from beatlog.model.context import Context, Outputs
from beatlog.model.state import RobotState

__all__ = ["CHANGES", "DogState", "Tuning", "changed_system", "system"]


class DogState(RobotState, kw_only=True):
    """The dog's light robot state: latest sensor readings and derived variables."""

    range_left: float = 1.5
    range_front: float = 1.5
    range_right: float = 1.5
    nearest: float = 1.5
    """The smallest of the three ranges (derived)."""
    obstacle_bearing: int = 0
    """+1 when the nearest obstacle is on the left, -1 on the right, 0 when none is near."""
    touch_head: bool = False
    touch_back: bool = False
    touch_chin: bool = False
    bumped: bool = False
    """The nose touch sensor was pressed since the last heartbeat."""
    accel_x: float = 0.0
    accel_y: float = 0.0
    accel_z: float = 9.81
    gyro_z: float = 0.0
    tilt: float = 0.0
    """Degrees between the torso's up axis and the measured gravity (derived)."""
    heading: float = 0.0
    """Locomotion direction (rad), integrated from the gyro (derived)."""
    speed: float = 0.0
    """Forward speed from leg odometry, low-passed (m/s)."""
    knee_mean: float = -1.45
    """Mean knee angle (rad): about -1.45 standing, below -2 lying (derived)."""
    battery: float = 100.0
    charging: bool = False
    beacon_bearing: float = 0.0
    beacon_distance: float = 9.9
    motion: str = "stand"
    """What the motion module is executing, and at what commanded speed and turn."""
    walk_speed: float = 0.0
    walk_turn: float = 0.0
    remote_seq: int = 0
    """How many remote commands arrived so far."""
    remote_active: bool = False
    remote_speed: float = 0.0
    remote_turn: float = 0.0
    happiness: int = 50
    """Emotions, as the emotion model last reported them (derived)."""
    boredom: int = 0


@dataclass(frozen=True)
class Tuning:
    """Every threshold and duration the behaviors use, so one can be changed at a time."""

    fall_tilt: float = 60.0
    fall_confirm_s: float = 0.3
    upright_tilt: float = 20.0
    remote_gain: float = 1.0
    remote_timeout_s: float = 1.0
    escape_back_s: float = 1.0
    stuck_s: float = 2.0
    chin_shake_s: float = 1.2
    sit_min_s: float = 2.0
    sit_extra_s: float = 2.0
    """Sitting lasts the minimum plus a random extra of up to this."""
    lie_s: float = 3.0
    low_battery: float = 20.0
    full_battery: float = 90.0
    sleep_boredom: int = 80
    wake_boredom: int = 20
    avoid_distance: float = 0.35
    avoid_clear: float = 0.6
    wall_distance: float = 0.3
    wall_follow_min_s: float = 4.0
    wall_follow_max_s: float = 8.0
    wander_speed: float = 0.18
    boredom_rate: float = 1.5
    """Boredom gained per second when nothing happens."""


CHANGES: dict[str, dict[str, float]] = {
    "get_up": {"fall_confirm_s": 0.4},
    "remote": {"remote_gain": 0.9},
    "escape": {"escape_back_s": 1.3},
    "chin": {"chin_shake_s": 1.5},
    "head_pat": {"sit_min_s": 2.5},
    "back_touch": {"lie_s": 3.5},
    "recharge": {"low_battery": 25.0},
    "sleep": {"sleep_boredom": 70},
    "avoid": {"avoid_distance": 0.45},
    "wall_follow": {"wall_distance": 0.35},
    "wander": {"wander_speed": 0.2},
    "emotion": {"boredom_rate": 1.6},
}
"""One deliberate change per behavior, for showing that the suite catches each."""

SECOND = 1_000_000_000


def _walk(speed: float, turn: float) -> Outputs:
    return {"motion": "walk", "speed": speed, "turn": turn}


def _pose(motion: str) -> Outputs:
    return {"motion": motion}


def _until(ctx: Context, seconds: float) -> int:
    return ctx.time_ns + int(seconds * SECOND)


class GetUp:
    """Detects a fall from the accelerometer's tilt, then runs the get-up motion."""

    name = "get_up"

    def __init__(self, tuning: Tuning) -> None:
        self.state: BehaviorState = "upright"
        self._t = tuning
        self._since: int | None = None

    def step(self, rs: DogState, ctx: Context) -> Outputs | None:
        t = self._t
        if self.state == "upright":
            if rs.tilt <= t.fall_tilt:
                self._since = None
                return None
            if self._since is None:
                self._since = ctx.time_ns
            if ctx.time_ns - self._since < t.fall_confirm_s * SECOND:
                return None
            self.state = "getting_up"
            self._since = None
        if rs.tilt > t.upright_tilt:
            self._since = None
        elif self._since is None:
            self._since = ctx.time_ns
        elif ctx.time_ns - self._since >= SECOND // 2:
            self.state = "upright"
            self._since = None
            return _pose("stand")
        return _pose("getup")


class Remote:
    """Remote-control override: drives as commanded while commands keep coming."""

    name = "remote"

    def __init__(self, tuning: Tuning) -> None:
        self.state: BehaviorState = "off"
        self._t = tuning
        self._seq = 0
        self._last_ns = 0

    def step(self, rs: DogState, ctx: Context) -> Outputs | None:
        if rs.remote_seq != self._seq:
            self._seq = rs.remote_seq
            self._last_ns = ctx.time_ns
        fresh = ctx.time_ns - self._last_ns <= self._t.remote_timeout_s * SECOND
        if rs.remote_active and fresh:
            self.state = "driving"
            gain = self._t.remote_gain
            return _walk(rs.remote_speed * gain, rs.remote_turn * gain)
        self.state = "off"
        return None


class Escape:
    """Bumped its nose or stuck: back up, then turn a random way for a random time."""

    name = "escape"

    def __init__(self, tuning: Tuning) -> None:
        self.state: BehaviorState = "idle"
        self._t = tuning
        self._until = 0
        self._direction = 1.0
        self._stuck_since: int | None = None

    def _stuck(self, rs: DogState, ctx: Context) -> bool:
        if rs.motion != "walk" or rs.walk_speed < 0.05 or rs.speed > 0.02:
            self._stuck_since = None
            return False
        if self._stuck_since is None:
            self._stuck_since = ctx.time_ns
        return ctx.time_ns - self._stuck_since >= self._t.stuck_s * SECOND

    def step(self, rs: DogState, ctx: Context) -> Outputs | None:
        stuck = self._stuck(rs, ctx)
        if self.state == "idle":
            if not (rs.bumped or stuck):
                return None
            self.state = "backing"
            self._stuck_since = None
            self._until = _until(ctx, self._t.escape_back_s)
        if self.state == "backing":
            if ctx.time_ns < self._until:
                return _walk(-0.12, 0.0)
            self.state = "turning"
            self._direction = ctx.random.choice((-1.0, 1.0))
            self._until = _until(ctx, ctx.random.uniform(0.8, 1.6))
        if ctx.time_ns < self._until:
            return _walk(0.0, 1.0 * self._direction)
        self.state = "idle"
        return None


class _TouchResponse(ABC):
    """A response that a touch sensor starts when pressed (a rising edge), for a while."""

    name = ""
    active: BehaviorState = ""

    def __init__(self, tuning: Tuning) -> None:
        self.state: BehaviorState = "idle"
        self._t = tuning
        self._was_touched = False
        self._started = 0
        self._until = 0

    @abstractmethod
    def _touched(self, rs: DogState) -> bool: ...

    @abstractmethod
    def _duration_s(self, ctx: Context) -> float: ...

    @abstractmethod
    def _respond(self, ctx: Context) -> Outputs: ...

    def step(self, rs: DogState, ctx: Context) -> Outputs | None:
        touched = self._touched(rs)
        if touched and not self._was_touched and self.state == "idle":
            self.state = self.active
            self._started = ctx.time_ns
            self._until = _until(ctx, self._duration_s(ctx))
        self._was_touched = touched
        if self.state == "idle":
            return None
        if ctx.time_ns >= self._until:
            self.state = "idle"
            return None
        return self._respond(ctx)


class Chin(_TouchResponse):
    """Chin touched: shake the head (turn left and right) for a moment."""

    name = "chin"
    active = "shaking"

    def _touched(self, rs: DogState) -> bool:
        return rs.touch_chin

    def _duration_s(self, ctx: Context) -> float:
        return self._t.chin_shake_s

    def _respond(self, ctx: Context) -> Outputs:
        swing = (ctx.time_ns - self._started) // (3 * SECOND // 10) % 2
        return _walk(0.0, 1.5 if swing else -1.5)


class HeadPat(_TouchResponse):
    """Head patted: sit for a random while (the emotion model makes it happier)."""

    name = "head_pat"
    active = "sitting"

    def _touched(self, rs: DogState) -> bool:
        return rs.touch_head

    def _duration_s(self, ctx: Context) -> float:
        return self._t.sit_min_s + ctx.random.uniform(0.0, self._t.sit_extra_s)

    def _respond(self, ctx: Context) -> Outputs:
        return _pose("sit")


class BackTouch(_TouchResponse):
    """Back stroked: lie down for a few seconds."""

    name = "back_touch"
    active = "lying"

    def _touched(self, rs: DogState) -> bool:
        return rs.touch_back

    def _duration_s(self, ctx: Context) -> float:
        return self._t.lie_s

    def _respond(self, ctx: Context) -> Outputs:
        return _pose("lie")


class Recharge:
    """Low battery: walk towards the charging pad's beacon, lie on it, charge until full."""

    name = "recharge"

    def __init__(self, tuning: Tuning) -> None:
        self.state: BehaviorState = "ok"
        self._t = tuning

    def step(self, rs: DogState, ctx: Context) -> Outputs | None:
        t = self._t
        if self.state == "ok":
            if rs.battery >= t.low_battery:
                return None
            self.state = "seeking"
        if self.state == "seeking":
            if rs.beacon_distance < 0.15:
                self.state = "docked"
            elif rs.range_front < t.avoid_distance:
                return None  # let avoid steer round the obstacle
            else:
                bearing = rs.beacon_bearing
                turn = max(-1.0, min(1.0, 1.5 * bearing))
                return _walk(0.15 if abs(bearing) < 0.6 else 0.0, turn)
        if self.state == "docked" and rs.charging:
            self.state = "charging"
        if self.state == "charging" and rs.battery >= t.full_battery:
            self.state = "ok"
            return None
        return _pose("lie")


class Sleep:
    """Bored: lie down and doze until boredom has passed or someone touches the dog."""

    name = "sleep"

    def __init__(self, tuning: Tuning) -> None:
        self.state: BehaviorState = "awake"
        self._t = tuning

    def step(self, rs: DogState, ctx: Context) -> Outputs | None:
        if self.state == "awake":
            if rs.boredom < self._t.sleep_boredom:
                return None
            self.state = "lying_down"
        if rs.touch_head or rs.touch_back or rs.touch_chin or rs.boredom <= self._t.wake_boredom:
            self.state = "awake"
            return None
        if self.state == "lying_down" and rs.knee_mean < -2.0:
            self.state = "asleep"
        return _pose("lie")


class Avoid:
    """Turns away from the nearer side while something is close ahead."""

    name = "avoid"

    def __init__(self, tuning: Tuning) -> None:
        self.state: BehaviorState = "clear"
        self._t = tuning

    def step(self, rs: DogState, ctx: Context) -> Outputs | None:
        t = self._t
        if self.state == "clear":
            if rs.range_front >= t.avoid_distance and min(rs.range_left, rs.range_right) >= 0.2:
                return None
            self.state = "turning_right" if rs.range_left < rs.range_right else "turning_left"
        elif rs.range_front > t.avoid_clear and rs.nearest > 0.25:
            self.state = "clear"
            return None
        return _walk(0.0, -0.9 if self.state == "turning_right" else 0.9)


class WallFollow:
    """A wall alongside: keep a steady distance from it for a random while."""

    name = "wall_follow"

    def __init__(self, tuning: Tuning) -> None:
        self.state: BehaviorState = "off"
        self._t = tuning
        self._until = 0
        self._rest_until = 0

    def step(self, rs: DogState, ctx: Context) -> Outputs | None:
        t = self._t
        if self.state == "off":
            if ctx.time_ns < self._rest_until or rs.range_front < t.avoid_clear:
                return None
            if rs.range_left < 0.5:
                self.state = "following_left"
            elif rs.range_right < 0.5:
                self.state = "following_right"
            else:
                return None
            self._until = _until(ctx, ctx.random.uniform(t.wall_follow_min_s, t.wall_follow_max_s))
        left = self.state == "following_left"
        side = rs.range_left if left else rs.range_right
        if ctx.time_ns >= self._until or side > 0.8 or rs.range_front < t.avoid_distance:
            self.state = "off"
            self._rest_until = _until(ctx, 5.0)
            return None
        error = side - t.wall_distance
        turn = max(-0.8, min(0.8, 2.0 * error))
        return _walk(0.15, turn if left else -turn)


class Wander:
    """Walks in segments of random length, some veering at a random rate."""

    name = "wander"

    def __init__(self, tuning: Tuning) -> None:
        self.state: BehaviorState = "straight"
        self._t = tuning
        self._turn = 0.0
        self._segment_end = 0

    def step(self, rs: DogState, ctx: Context) -> Outputs | None:
        if ctx.time_ns >= self._segment_end:
            chance = ctx.random
            veer = chance.random() < 0.4
            self._turn = chance.gauss(0.0, 0.4) if veer else 0.0
            self.state = "veering" if veer else "straight"
            self._segment_end = _until(ctx, chance.uniform(2.0, 5.0))
        return _walk(self._t.wander_speed, self._turn)


class Emotion:
    """Happiness and boredom: touches and company cheer, idleness bores, chance stirs.

    Its state is the mood; the levels are reported as outputs every cycle and come
    back in the robot state, where the other behaviors read them.
    """

    name = "emotion"

    def __init__(self, tuning: Tuning) -> None:
        self.state: BehaviorState = "content"
        self._t = tuning
        self._happiness = 50.0
        self._boredom = 0.0
        self._was_touched = False
        self._next_fluctuation = SECOND

    def step(self, rs: DogState, ctx: Context) -> Outputs | None:
        dt = ctx.dt
        happiness, boredom = self._happiness, self._boredom
        touched = rs.touch_head or rs.touch_back or rs.touch_chin
        if touched and not self._was_touched:
            boredom -= 40.0
            happiness += 20.0 if rs.touch_head else 5.0
        self._was_touched = touched
        if rs.remote_active:
            boredom -= 2.0 * dt
        elif rs.motion == "lie":
            boredom -= 4.0 * dt
        else:
            boredom += self._t.boredom_rate * dt
        happiness += (50.0 - happiness) * 0.02 * dt
        if rs.battery < 30.0:
            happiness -= 0.5 * dt
        if ctx.time_ns >= self._next_fluctuation:
            happiness += ctx.random.gauss(0.0, 3.0)
            self._next_fluctuation += SECOND
        self._happiness = happiness = min(100.0, max(0.0, happiness))
        self._boredom = boredom = min(100.0, max(0.0, boredom))
        if boredom >= 60.0:
            self.state = "bored"
        elif happiness >= 70.0:
            self.state = "happy"
        elif happiness < 30.0:
            self.state = "sad"
        else:
            self.state = "content"
        ctx.emit("happiness", round(happiness))
        ctx.emit("boredom", round(boredom))
        return None


BEHAVIORS = (
    GetUp,
    Remote,
    Escape,
    Chin,
    HeadPat,
    BackTouch,
    Recharge,
    Sleep,
    Avoid,
    WallFollow,
    Wander,
    Emotion,
)


def system(tuning: Tuning | None = None) -> PriorityArbiter[DogState]:
    """The dog's behavior system, highest priority first."""
    chosen = tuning if tuning is not None else Tuning()
    return PriorityArbiter([kind(chosen) for kind in BEHAVIORS], robot_state=DogState)


def changed_system(behavior: str = "avoid") -> PriorityArbiter[DogState]:
    """The system with one behavior deliberately changed (see :data:`CHANGES`)."""
    return system(dataclasses.replace(Tuning(), **CHANGES[behavior]))  # type: ignore[arg-type]
