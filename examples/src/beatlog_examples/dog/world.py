"""The dog's world in MuJoCo: physics, the motion module, the battery and the tester's hands.

This is the environment and the robot's firmware, not the software under test: it
runs only while recording and is never replayed. A human tester acts on it through
:meth:`DogWorld.place`, :meth:`~DogWorld.touch`, :meth:`~DogWorld.push`,
:meth:`~DogWorld.hold`, :meth:`~DogWorld.drag`, :meth:`~DogWorld.lean` and
:meth:`~DogWorld.drain` and :meth:`~DogWorld.swap_battery`, as a person would on the
real robot; behaviors only ever see the result through the sensors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from beatlog_examples.dog.gait import Gait, Motion
from beatlog_examples.dog.model import load_model, sensor_slice

__all__ = ["BOXES", "CHARGER", "RANGE_FINDERS", "TOUCH_PARTS", "Battery", "DogWorld"]

CHARGER = (0.8, 3.2)
"""Centre of the charging pad (m), as in ``arena.xml``."""
CHARGER_RADIUS = 0.25
BOXES = ("box1", "box2", "box3")
"""The boxes a tester can place; they wait outside the arena until then."""
TOUCH_PARTS = {"head": "head_top", "back": "back", "chin": "chin"}
"""Where a tester's hand can touch the dog: part name to the touch sensor's site."""
HAND_RADIUS = 0.04
HAND_PRESS = 0.002
"""How deep (m) the tester's hand presses into the dog, unless told otherwise."""
PUSH_FORCE_N = 25.0
PUSH_S = 0.1
HOLD_STIFFNESS = 300.0
HOLD_DAMPING = 30.0
LEAN_STIFFNESS = 30.0
"""N·m per radian of roll from the angle the tester's hands tip the dog to."""
LEAN_DAMPING = 1.5
LEAN_RAMP_S = 0.5
"""The tester tips the dog over this long, and sets it back upright as long."""
RIGHTING_TORQUE = 3.0
RIGHTING_DAMPING = 0.3
"""The get-up routine: legs tucked while a torque turns the torso upright (see README)."""
PARKED_HAND = (10.0, 10.0, 2.0)
RANGE_FINDERS = ("left", "front", "right")
"""The range finders a tester can place a box in front of, by the reading they watch."""


@dataclass
class Battery:
    """Charge in [0, 1]: drains faster while walking, charges lying on the pad."""

    level: float = 1.0
    idle_drain: float = 0.0006
    """Per second."""
    walk_drain: float = 0.0008
    charge_rate: float = 0.02
    extra_drain: float = 0.0
    """Per second: a load the tester switches on; it also slows charging."""
    charging: bool = False

    def update(self, dt: float, *, walking: bool, docked: bool) -> None:
        """Account for ``dt`` seconds of use or charging."""
        self.charging = docked
        if docked:
            change = self.charge_rate - self.extra_drain
        else:
            change = -(self.idle_drain + self.extra_drain + (self.walk_drain if walking else 0.0))
        self.level = min(1.0, max(0.0, self.level + change * dt))


class DogWorld:
    """The arena with the dog in it, stepped one physics step (2 ms) at a time."""

    def __init__(
        self, *, x: float = 1.0, y: float = 2.0, heading: float = 0.0, battery: float = 1.0
    ) -> None:
        self.model = model = load_model()
        self.data = data = mujoco.MjData(model)
        self.timestep = float(model.opt.timestep)
        self.gait = Gait()
        self.motion = Motion.STAND
        self.speed = 0.0
        self.turn = 0.0
        self.battery = Battery(level=battery)
        self._torso = model.body("torso").id
        self._hand = int(model.body("hand").mocapid[0])
        self._boxes = {name: int(model.body(name).mocapid[0]) for name in BOXES}
        self._sites = {part: model.site(site).id for part, site in TOUCH_PARTS.items()}
        self._touching: float | None = None
        self._pushing: tuple[npt.NDArray[np.float64], float] | None = None
        self._holding: tuple[npt.NDArray[np.float64], float] | None = None
        self._dragging: tuple[float, float] | None = None
        self._leaning: tuple[float, float, float] | None = None
        data.qpos[:3] = (x, y, 0.17)
        data.qpos[3:7] = (math.cos(heading / 2), 0.0, 0.0, math.sin(heading / 2))
        data.ctrl[:] = self.gait.targets
        mujoco.mj_forward(model, data)

    @property
    def time_s(self) -> float:
        """Simulated time since the world was made."""
        return float(self.data.time)

    @property
    def pose(self) -> tuple[float, float, float]:
        """Ground truth x, y (m) and heading (rad) of the torso, for tests and scenarios."""
        rotation = self.data.xmat[self._torso]
        x, y = self.data.xpos[self._torso][:2]
        return float(x), float(y), math.atan2(rotation[3], rotation[0])

    @property
    def upright(self) -> float:
        """Cosine of the torso's tilt: 1 standing, 0 on its side, -1 on its back."""
        return float(self.data.xmat[self._torso][8])

    @property
    def docked(self) -> bool:
        """Lying on the charging pad."""
        x, y, _heading = self.pose
        on_pad = math.hypot(x - CHARGER[0], y - CHARGER[1]) < CHARGER_RADIUS
        return on_pad and self.motion is Motion.LIE

    def command(self, motion: str, speed: float = 0.0, turn: float = 0.0) -> None:
        """Ask the motion module for a motion; unknown motions stand still."""
        try:
            self.motion = Motion(motion)
        except ValueError:
            self.motion = Motion.STAND
        self.speed = speed
        self.turn = turn

    def step(self) -> None:
        """One physics step: joint targets from the gait, the tester's hands, the battery."""
        data = self.data
        dt = self.timestep
        data.ctrl[:] = self.gait.step(dt, self.motion, self.speed, self.turn)
        self._act_on_torso()
        if self._touching is not None:
            self._release()
        mujoco.mj_step(self.model, data)
        walking = self.motion is Motion.WALK and bool(self.speed or self.turn)
        self.battery.update(dt, walking=walking, docked=self.docked)

    def place(self, box: str, x: float, y: float) -> None:
        """Put a box (one of :data:`BOXES`) on the floor at (x, y)."""
        self.data.mocap_pos[self._boxes[box]] = (x, y, 0.15)

    def place_at_range(self, box: str, finder: str, metres: float) -> None:
        """Put a box on the floor across a range finder's beam (one of
        :data:`RANGE_FINDERS`), where that finder reads ``metres`` without noise: a
        tester watching the live reading and nudging the box, done by bisection."""
        site = self.model.site(f"range_{finder}").id
        beam = self.data.site_xmat[site].reshape(3, 3)[:2, 2]
        beam = beam / np.linalg.norm(beam)
        origin = self.data.site_xpos[site][:2].copy()
        reading = sensor_slice(self.model, f"range_{finder}").start
        near, far = 0.0, metres + 2.0 * max(self.model.geom_size[self._box_geom(box)][:2])
        for _ in range(40):
            centre = (near + far) / 2
            self.place(box, *(origin + centre * beam))
            mujoco.mj_forward(self.model, self.data)
            seen = float(self.data.sensordata[reading])
            if 0.0 <= seen < metres:
                near = centre
            else:
                far = centre
        self.place(box, *(origin + far * beam))
        mujoco.mj_forward(self.model, self.data)

    def _box_geom(self, box: str) -> int:
        return int(self.model.body_geomadr[self.model.body(box).id])

    def remove(self, box: str) -> None:
        """Take a box out of the arena again."""
        self.data.mocap_pos[self._boxes[box]] = (10.0, float(self._boxes[box]), 0.15)

    def touch(self, part: str, seconds: float, press: float = HAND_PRESS) -> None:
        """Rest a hand on the head, back or chin for a while, where the part is now,
        pressing ``press`` metres into it (a lighter touch presses less)."""
        site = self.data.site_xpos[self._sites[part]]
        below = -1.0 if part == "chin" else 1.0
        self.data.mocap_pos[self._hand] = site + np.array((0.0, 0.0, below * (HAND_RADIUS - press)))
        self._touching = self.time_s + seconds

    def push(self, side: int = 1) -> None:
        """Shove the dog sideways (+1 towards its left, -1 its right), hard enough to fall."""
        rotation = self.data.xmat[self._torso].reshape(3, 3)
        force = rotation[:, 1] * (PUSH_FORCE_N * side)
        force[2] = 0.0
        self._pushing = (force, self.time_s + PUSH_S)

    def hold(self, seconds: float) -> None:
        """Hold the dog in place by its body, so its legs walk without getting anywhere."""
        self._holding = (self.data.xpos[self._torso].copy(), self.time_s + seconds)

    def drag(self, seconds: float, damping: float) -> None:
        """Hold the dog back by its harness: a pull against its velocity, ``damping`` N
        per m/s, so it walks on slowly instead of not at all."""
        self._dragging = (damping, self.time_s + seconds)

    def lean(self, side: int, degrees: float, seconds: float) -> None:
        """Tip the dog towards its left (+1) or right (-1) by about ``degrees``, keep it
        there and set it back upright, ``seconds`` in all, as a tester's hands would."""
        self._leaning = (-side * math.radians(degrees), self.time_s, self.time_s + seconds)

    def drain(self, per_second: float) -> None:
        """Switch on a load that draws ``per_second`` of the charge (a tester running the
        dog down before a test): the battery drains faster, and charges slower on the pad."""
        self.battery.extra_drain = per_second

    def swap_battery(self, level: float) -> None:
        """Swap in another battery, charged to ``level`` (in [0, 1])."""
        self.battery.level = level

    def _act_on_torso(self) -> None:
        applied = self.data.xfrc_applied[self._torso]
        applied[:] = 0.0
        now = self.time_s
        if self._pushing is not None:
            force, until = self._pushing
            if now < until:
                applied[:3] += force
            else:
                self._pushing = None
        if self._holding is not None:
            anchor, until = self._holding
            if now < until:
                offset = self.data.xpos[self._torso] - anchor
                velocity = self.data.qvel[:3]
                applied[:2] -= HOLD_STIFFNESS * offset[:2] + HOLD_DAMPING * velocity[:2]
            else:
                self._holding = None
        if self._dragging is not None:
            damping, until = self._dragging
            if now < until:
                applied[:2] -= damping * self.data.qvel[:2]
            else:
                self._dragging = None
        rotation = self.data.xmat[self._torso].reshape(3, 3)
        roll = math.atan2(rotation[2, 1], rotation[2, 2])  # from world up in the torso frame
        spin = rotation @ self.data.qvel[3:6]
        if self._leaning is not None:
            angle, start, until = self._leaning
            if now < until:
                target = angle * min(1.0, (now - start) / LEAN_RAMP_S, (until - now) / LEAN_RAMP_S)
                torque = LEAN_STIFFNESS * (target - roll)
                applied[3:] += torque * rotation[:, 0] - LEAN_DAMPING * spin
            else:
                self._leaning = None
        if self.motion is Motion.GETUP:
            torque = -math.copysign(RIGHTING_TORQUE * min(1.0, abs(roll)), roll)
            applied[3:] += torque * rotation[:, 0] - RIGHTING_DAMPING * spin

    def _release(self) -> None:
        assert self._touching is not None
        if self.time_s >= self._touching:
            self._touching = None
            self.data.mocap_pos[self._hand] = PARKED_HAND
