"""Systems the tests replay beside the probe of ``conftest``: deliberate changes to it,
behaviors that break, hostile names, and behaviors that break the determinism discipline.

Specs and ``--system`` name them as ``tests.systems:FACTORY``, and the audit's fresh
interpreters import them from here. Each leak of :class:`Leaky` is one line ending in
``# leak: CALL``; the tests find the lines by it.
"""

from __future__ import annotations

import datetime
import inspect
import itertools
import logging
import math
import os
import random
import secrets
import signal
import time
import uuid
from collections.abc import Sequence
from datetime import datetime as wall_datetime
from pathlib import Path
from time import monotonic
from typing import Any

import msgspec
import numpy as np
import py_trees

from beatlog.model.behavior import BehaviorState, PriorityArbiter, System
from beatlog.model.context import Context, Outputs
from beatlog.model.inbox import Sample
from beatlog.model.invariant import Cycle
from beatlog.model.random import RecordingRandom
from beatlog.model.source import RandomSource
from beatlog.model.state import RobotState
from beatlog.record.recorder import Recorder
from beatlog_examples.rover import RoverRobot, RoverState
from tests.conftest import PERIOD_NS, Dice, Near, Probe, probe_system
from tests.crafting import Gauge

HEADINGS = ("left", "right", "straight", "back")
HOSTILE = "<script>alert('x')</script>"
TEX = "$\\frac{1}{0}$"


def probe_system_changed_again() -> PriorityArbiter[Probe]:
    """On top of ``probe_system_changed``, near reacts earlier still: new state changes."""
    return probe_system(0.7)


def probe_system_blind() -> PriorityArbiter[Probe]:
    """A probe whose near never sees the pole: its state changes are lost, as the dog's
    escapes were when a retune left it never stuck."""
    return probe_system(0.0)


class Geared(Dice):
    """Dice with a new motor gain near the obstacle: a change in outputs only."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        outputs = super().step(rs, ctx)
        assert outputs is not None
        return {**outputs, "speed": 0.55 if rs.distance < 0.8 else 0.5}


def probe_system_changed_geared() -> PriorityArbiter[Probe]:
    """On top of ``probe_system_changed``, a changed motor gain."""
    return PriorityArbiter([Near(0.6), Geared()], robot_state=Probe)


def probe_system_greedy() -> PriorityArbiter[Probe]:
    """A probe that draws two random numbers where one was recorded."""
    return probe_system(draws=2)


def probe_system_greedier() -> PriorityArbiter[Probe]:
    """A probe that draws three random numbers where one was recorded."""
    return probe_system(draws=3)


def probe_system_greedy_wide() -> PriorityArbiter[Probe]:
    """A greedy probe whose rolls are of a die of eight."""
    return PriorityArbiter([Near(), WideDice(5, 2)], robot_state=Probe)


class WideDice(Dice):
    """Dice rolling a die of eight."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        if ctx.cycle % self.every == 0:
            for _ in range(self.draws):
                roll = ctx.random.randint(1, 8)
            self.state = "odd" if roll % 2 else "even"
        return {"speed": 0.5, "time": ctx.time}


def not_a_system() -> dict[str, object]:
    """A factory that builds something other than a system."""
    return {"robot_state": Probe, "behaviors": {}}


class Dozy(Dice):
    """Dice that dozes off from cycle 10: it goes ``dozing`` where it rolled."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        if ctx.cycle >= 10 and ctx.cycle % self.every == 0:
            self.state = "dozing"
            return {"speed": 0.5, "time": ctx.time}
        return super().step(rs, ctx)


def dozy_system() -> PriorityArbiter[Probe]:
    return PriorityArbiter([Near(), Dozy()], robot_state=Probe)


class Impostor(Dice):
    """Dice whose arbiter credits its draws to the behavior before it (an off-by-one in
    the actor numbering)."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        ctx.actor -= 1
        try:
            return super().step(rs, ctx)
        finally:
            ctx.actor += 1


def impostor_system() -> PriorityArbiter[Probe]:
    return PriorityArbiter([Near(), Impostor()], robot_state=Probe)


class Fragile(Dice):
    """Dice that breaks on a close obstacle."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        if rs.distance < 0.3:
            raise ZeroDivisionError("fragile dice")
        return super().step(rs, ctx)


def fragile_system() -> PriorityArbiter[Probe]:
    """The probe with dice that breaks on a close obstacle."""
    return PriorityArbiter([Near(), Fragile()], robot_state=Probe)


class Weary(Near):
    """Near that wears out: it raises on its fourth approach to the pole, a bug that
    only a state reached late in a session (after three approaches) triggers."""

    def __init__(self, threshold: float = 0.5) -> None:
        super().__init__(threshold)
        self.approaches = 0

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        was = self.state
        outputs = super().step(rs, ctx)
        if was == "far" and self.state == "near":
            self.approaches += 1
            if self.approaches == WORN_OUT:
                raise RuntimeError("worn out")
        return outputs


WORN_OUT = 4
"""The approach on which :class:`Weary` raises."""


def weary_system() -> PriorityArbiter[Probe]:
    """The probe with a near that raises on its fourth approach."""
    return PriorityArbiter([Weary(), Dice()], robot_state=Probe)


def weary_system_changed() -> PriorityArbiter[Probe]:
    """``probe_system_changed`` (near reacts earlier), with a near that raises on its
    fourth approach."""
    return PriorityArbiter([Weary(0.6), Dice()], robot_state=Probe)


class Hostile:
    """A behavior whose name and states are markup and TeX, as user data may be."""

    name = HOSTILE

    def __init__(self) -> None:
        self.state: BehaviorState = TEX

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        self.state = "<b>near</b>" if rs.distance < 0.5 else TEX
        return None


def hostile_system() -> PriorityArbiter[Probe]:
    return PriorityArbiter([Hostile()], robot_state=Probe)


class Leaky:
    """Reads the wall clock and global generators every cycle, one call a line.

    Its own state and output stay put, so its replays pass: only the audit catches it.
    """

    name = "leaky"
    state = "calm"

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        print("leaky steps")  # what behaviors print must not confuse the audit
        monotonic()  # leak: time.monotonic
        time.time()  # leak: time.time
        time.perf_counter_ns()  # leak: time.perf_counter_ns
        wall_datetime.now()  # leak: datetime.datetime.now
        datetime.date.today()  # leak: datetime.date.today
        random.random()  # leak: random.random
        random.choice(["left", "right"])  # leak: random.choice
        random.shuffle([1, 2, 3])  # leak: random.shuffle
        np.random.rand()  # leak: numpy.random
        secrets.token_hex(4)  # leak: os.urandom
        uuid.uuid4()  # leak: uuid.uuid4
        return {"mood": self.state}


def leaks() -> list[tuple[str, str]]:
    """(call, site) of every line of :meth:`Leaky.step` marked ``# leak: CALL``, in order."""
    lines, first = inspect.getsourcelines(Leaky.step)
    return [
        (text.split("# leak: ")[1].strip(), f"{__file__}:{first + offset} in Leaky.step")
        for offset, text in enumerate(lines)
        if "# leak: " in text
    ]


class Disciplined:
    """Uses only the context for time and chance, and logs, which is no leak."""

    name = "disciplined"
    state = "calm"

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        logging.getLogger(__name__).debug("t = %s", ctx.time)
        private = random.Random(ctx.cycle).random() + np.random.default_rng(ctx.cycle).random()
        self.state = "calm" if ctx.random.random() + private < 1.5 else "excited"
        return {"t": ctx.time}


class Unordered:
    """Picks a heading by set order of strings, which follows the hash seed."""

    name = "unordered"
    state = "left"

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        self.state = list(set(HEADINGS))[ctx.cycle % len(HEADINGS)]
        return None


def record_session(path: Path, system: System, cycles: int = 20) -> Path:
    """Record ``cycles`` cycles of ``system`` at a steady heartbeat and return the log."""
    with Recorder(path, system, seed=3, software="test") as recorder:
        for _ in range(cycles):
            recorder.step(PERIOD_NS, Probe())
    return path


def quiet_system() -> PriorityArbiter[Probe]:
    """The probe's near alone: far from everything in :func:`record_session`'s sessions,
    it never changes state, outputs or draws, so their replays check nothing."""
    return PriorityArbiter([Near()], robot_state=Probe)


def leaky_system() -> PriorityArbiter[Probe]:
    return PriorityArbiter([Leaky()], robot_state=Probe)


def unordered_system() -> PriorityArbiter[Probe]:
    return PriorityArbiter([Unordered()], robot_state=Probe)


class Scripted:
    """Goes through the given headings: what :class:`Unordered` did under some hash seed."""

    name = "unordered"
    state = "left"

    def __init__(self, headings: list[str]) -> None:
        self.headings = headings

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        self.state = self.headings[ctx.cycle % len(self.headings)]
        return None


def scripted_system(headings: list[str]) -> PriorityArbiter[Probe]:
    return PriorityArbiter([Scripted(headings)], robot_state=Probe)


def exiting_system() -> PriorityArbiter[Probe]:
    """A factory that ends the interpreter at once: the audit's replay dies without an answer."""
    os._exit(70)


def interrupted_system() -> PriorityArbiter[Probe]:
    """A factory whose interpreter gets Ctrl-C (SIGINT) before the process auditing it."""
    os.kill(os.getpid(), signal.SIGINT)
    raise AssertionError("SIGINT did not end the interpreter")


class Gambler:
    """Picks a heading with the global, unseeded random generator."""

    name = "gambler"
    state = "left"

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        self.state = random.choice(HEADINGS)
        return None


def gambler_system() -> PriorityArbiter[Probe]:
    return PriorityArbiter([Gambler()], robot_state=Probe)


_BUILT = itertools.count()


class Restless:
    """Takes, at its fifth heartbeat, a state named after how many of its kind were built
    before it: module state that outlives a replay, so every replay of one log fails
    otherwise, whatever the order of the tests."""

    name = "restless"
    state = "waiting"

    def __init__(self) -> None:
        self.built = next(_BUILT)
        self.beats = 0

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        self.beats += 1
        if self.beats == 5:
            self.state = f"built {self.built}"
        return None


def restless_system() -> PriorityArbiter[Probe]:
    return PriorityArbiter([Restless()], robot_state=Probe)


class Drifter:
    """Picks a heading with a numpy generator of its own, made without a seed, as code
    written for a simulator does; ``seed`` seeds it."""

    name = "drifter"
    state = "left"

    def __init__(self, seed: int | None = None) -> None:
        self.rng = np.random.default_rng(seed)  # made

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        self.state = HEADINGS[self.rng.integers(len(HEADINGS))]  # drawn
        return None


def drifter_sites() -> tuple[str, str]:
    """Where :class:`Drifter` makes its generator, and where it draws from it."""
    sites = []
    for method in (Drifter.__init__, Drifter.step):
        lines, first = inspect.getsourcelines(method)
        offset = next(
            i for i, text in enumerate(lines) if text.rstrip().endswith(("# made", "# drawn"))
        )
        sites.append(f"{__file__}:{first + offset} in {method.__qualname__}")
    return sites[0], sites[1]


def drifter_system() -> PriorityArbiter[Probe]:
    return PriorityArbiter([Drifter()], robot_state=Probe)


def seeded_drifter_system() -> PriorityArbiter[Probe]:
    return PriorityArbiter([Drifter(seed=7)], robot_state=Probe)


class Moody(RobotState, kw_only=True):
    """A robot state with a text field, a number and a flag."""

    mood: str = "calm"
    level: int = 0
    bumped: bool = False


class Quiet:
    name = "quiet"
    state: BehaviorState = "idle"

    def step(self, rs: Moody, ctx: Context) -> Outputs | None:
        return None


def moody_system() -> PriorityArbiter[Moody]:
    return PriorityArbiter([Quiet()], robot_state=Moody)


def record_moody(path: Path) -> Path:
    """Ten cycles of :func:`moody_system`, ``level`` counting up and ``bumped`` flipping."""
    with Recorder(path, moody_system(), software="t") as recorder:
        for t in range(10):
            recorder.step(PERIOD_NS, Moody(level=t, bumped=t % 2 == 1))
    return path


class HandTickedTree:
    """A py_trees tree ticked by hand, without beatlog's adapter: its ``Timer`` reads the
    wall clock (``py_trees/timers.py``), whatever robot time says."""

    name = "patrol"
    state = "INVALID"

    def __init__(self) -> None:
        self.tree = py_trees.composites.Sequence(
            "patrol",
            memory=True,
            children=[
                py_trees.timers.Timer("pause", duration=3600.0),
                py_trees.behaviours.Success("go"),
            ],
        )

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        self.tree.tick_once()  # leak via: the user's frame that reached py_trees' timer
        self.state = self.tree.status.name
        return None


def hand_ticked_tree() -> PriorityArbiter[Probe]:
    return PriorityArbiter([HandTickedTree()], robot_state=Probe)


def gauge_system() -> PriorityArbiter[Gauge]:
    """The system of the logs ``tests.factories`` crafts: no behaviors, the Gauge state."""
    return PriorityArbiter([], robot_state=Gauge)


class Rover(RobotState, kw_only=True):
    """Another robot's state, which holds the probe's fields among its own."""

    distance: float = 1.0
    reading: float = 0.0
    heading: float = 0.0


def rover_system() -> PriorityArbiter[Any]:
    """The probe's behaviors on another robot's state."""
    return PriorityArbiter([Near(), Dice()], robot_state=Rover)


BUILT: list[str] = []
"""The systems :func:`counted_system` built: clear it before use."""


def counted_system() -> PriorityArbiter[Probe]:
    """The probe system, noting in :data:`BUILT` that it was built."""
    BUILT.append("probe")
    return probe_system()


class Ranged(RobotState, kw_only=True):
    """The probe's state with ``distance`` renamed to ``range`` since its logs were made."""

    range: float = 1.0
    reading: float = 0.0


class RangedNear(Near):
    """``near`` reading the renamed field."""

    def step(self, rs: Ranged, ctx: Context) -> Outputs | None:  # type: ignore[override]
        self.state = "near" if rs.range < self.threshold else "far"
        return {"speed": 0.0} if self.state == "near" else None


def probe_system_ranged(threshold: float = 0.5) -> PriorityArbiter[Any]:
    """The probe with ``distance`` renamed to ``range``: a rename that changes no behavior."""
    ranged: PriorityArbiter[Any] = PriorityArbiter(
        [RangedNear(threshold), Dice()], robot_state=Ranged
    )
    return ranged


def probe_system_ranged_changed() -> PriorityArbiter[Any]:
    """The renamed probe with ``near`` reacting earlier: a deliberate behavior change."""
    return probe_system_ranged(0.6)


def probe_system_ranged_broken() -> PriorityArbiter[Any]:
    """The renamed, changed probe with ``near`` reacting earlier still: a bug planted
    after the change was approved."""
    return probe_system_ranged(0.7)


class Centimetred(RobotState, kw_only=True):
    """The probe's state with ``distance`` retyped: whole centimetres, no longer metres."""

    distance: int = 100
    reading: float = 0.0


class CentimetredNear(Near):
    """``near`` reading the distance in centimetres."""

    def step(self, rs: Centimetred, ctx: Context) -> Outputs | None:  # type: ignore[override]
        self.state = "near" if rs.distance < self.threshold * 100 else "far"
        return {"speed": 0.0} if self.state == "near" else None


def probe_system_centimetred() -> PriorityArbiter[Any]:
    """The probe with ``distance`` in whole centimetres: a retype that changes no behavior."""
    centimetred: PriorityArbiter[Any] = PriorityArbiter(
        [CentimetredNear(), Dice()], robot_state=Centimetred
    )
    return centimetred


def centimetres(metres: float) -> int:
    """A recorded distance in metres as whole centimetres: the retyped field's conversion."""
    return round(metres * 100)


def centimetres_unless_close(metres: float) -> int:
    """A conversion that fails on a recorded value: distances under 0.1 m."""
    if metres < 0.1:
        raise ValueError(f"{metres} m is too close to convert")
    return centimetres(metres)


def centimetres_as_text(metres: float) -> str:
    """A conversion that returns a value of another type than the field's."""
    return f"{centimetres(metres)} cm"


class Pose(msgspec.Struct):
    x: float
    y: float


class Posed(RobotState, kw_only=True):
    """A robot state holding a struct."""

    pose: Pose = msgspec.field(default_factory=lambda: Pose(0.0, 0.0))


class PxPose(msgspec.Struct):
    px: float
    y: float


class PxPosed(RobotState, kw_only=True):
    """:class:`Posed` with ``pose.x`` renamed to ``pose.px`` since its logs were made."""

    pose: PxPose = msgspec.field(default_factory=lambda: PxPose(0.0, 0.0))


class Scatter:
    """Draws an array of uniform numbers every fifth cycle (``arrays`` of them), or none;
    its state says whether the first was below one half."""

    name = "scatter"

    def __init__(self, arrays: bool = True) -> None:
        self.state: BehaviorState = "low"
        self.arrays = arrays

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        if ctx.cycle % 5 == 0:
            first = ctx.random.uniform_array(0.0, 1.0, (2, 2))[0, 0] if self.arrays else 0.0
            self.state = "low" if first < 0.5 else "high"
        return None


def scatter_system() -> PriorityArbiter[Probe]:
    """A system that draws arrays, which need numpy."""
    return PriorityArbiter([Scatter()], robot_state=Probe)


def scatter_system_calm() -> PriorityArbiter[Probe]:
    """:func:`scatter_system` changed to draw nothing: replaying its log needs no numpy."""
    return PriorityArbiter([Scatter(arrays=False)], robot_state=Probe)


def record_scatter(path: Path, cycles: int = 30, *, seed: int = 3) -> Path:
    """A log of :func:`scatter_system`, whose draws are arrays."""
    with Recorder(path, scatter_system(), seed=seed, software="test") as recorder:
        for _ in range(cycles):
            recorder.step(PERIOD_NS, Probe())
    return path


class Simulated(RobotState, kw_only=True):
    """A robot state as a simulator may fill it: with numpy scalars, subclasses of int
    and float, or a tuple for a list; the log stores each as the field's type."""

    u: float = 0.0
    n: int = 0
    flag: bool = False
    xs: list[float] = msgspec.field(default_factory=list)


class Typist:
    """Computes with the robot state's values, and names their types in its state: it
    acts on the values exactly as they reach it."""

    name = "typist"
    state: BehaviorState = ""

    def step(self, rs: Simulated, ctx: Context) -> Outputs | None:
        self.state = ",".join(type(value).__name__ for value in (rs.u, rs.n, rs.flag, rs.xs))
        return {"u2": rs.u * rs.u - 0.98}


def typist_system() -> PriorityArbiter[Simulated]:
    return PriorityArbiter([Typist()], robot_state=Simulated)


def perceive_simulated(previous: Simulated | None, samples: Sequence[Sample]) -> Simulated:
    """A perception step as a simulator's: the last range reading, as a float32."""
    u = samples[-1].value if samples else 1.0
    return Simulated(u=np.float32(u), xs=(u,))  # type: ignore[arg-type]


def gambling_rover() -> RoverRobot:
    """The example rover driven by a :class:`Gambler`: no session of it replays."""
    return RoverRobot(behaviors=PriorityArbiter([Gambler()], robot_state=RoverState))


class Driver:
    """A driver whose desired speed and headway are picked once, when it is built (as
    driving code picks them per episode), in ``random.Random``'s dialect and numpy's;
    ``more`` draws that many integers besides."""

    name = "driver"

    def __init__(self, random: RandomSource, *, more: int = 0) -> None:
        self.state: BehaviorState = "cruise"
        self.speed = random.uniform(20.0, 30.0)
        self.headway = float(random.normal(2.0, 0.5, size=2).mean())
        self.lanes = [int(random.integers(0, 3)) for _ in range(more)]

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        self.state = "brake" if rs.distance < 0.5 else "cruise"
        return {"speed": self.speed, "headway": self.headway}


def driver_system(random: RandomSource) -> PriorityArbiter[Probe]:
    """A system whose factory draws at set-up: the probe's near, and a driver."""
    return PriorityArbiter([Near(), Driver(random)], robot_state=Probe)


def driver_system_drawing_more(random: RandomSource) -> PriorityArbiter[Probe]:
    """:func:`driver_system` whose driver draws one number more at set-up."""
    return PriorityArbiter([Near(), Driver(random, more=1)], robot_state=Probe)


def driver_system_settled(random: RandomSource) -> PriorityArbiter[Probe]:
    """:func:`driver_system` whose factory takes the random source but draws nothing:
    its driver draws from a source of its own, seeded 0."""
    return PriorityArbiter([Near(), Driver(RecordingRandom(seed=0))], robot_state=Probe)


def record_driver(path: Path, cycles: int = 20) -> Path:
    """Record ``cycles`` cycles of :func:`driver_system`, its set-up drawn from the
    recording's random source, approaching the pole."""
    random = RecordingRandom(seed=3)
    with Recorder(path, driver_system(random=random), random=random, software="test") as recorder:
        for cycle in range(cycles):
            recorder.step(PERIOD_NS, Probe(distance=1.0 - cycle / cycles))
    return path


class Heading:
    """Keeps the heading it picked when it was built, and says so every cycle."""

    name = "heading"

    def __init__(self, random: RandomSource) -> None:
        self.state: BehaviorState = random.choice(HEADINGS)

    def step(self, rs: RoverState, ctx: Context) -> Outputs | None:
        return {"heading": self.state}


def heading_rover(random: RandomSource) -> RoverRobot:
    """The example rover driven by a :class:`Heading`: its factory draws at set-up."""
    return RoverRobot(behaviors=PriorityArbiter([Heading(random)], robot_state=RoverState))


class Fussy(Near):
    """``near``, which raises where the distance is below zero: a bug no recording of
    the probe reaches (its distances never are), and noise on ``distance`` does."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        if rs.distance < 0:
            raise ValueError(f"a negative distance: {rs.distance}")
        return super().step(rs, ctx)


def fussy_system() -> PriorityArbiter[Probe]:
    """The probe system with :class:`Fussy` for ``near``."""
    return PriorityArbiter([Fussy(), Dice()], robot_state=Probe)


def never_close(cycle: Cycle) -> None:
    """An invariant of the probe that does not hold within 0.3 m of the pole."""
    if cycle.robot_state.distance <= 0.3:
        raise AssertionError(f"{cycle.robot_state.distance} m from the pole")


def never_holds(cycle: Cycle) -> None:
    """An invariant that holds in no cycle of any robot."""
    raise AssertionError(f"cycle {cycle.cycle}")


class NeverLingers:
    """An invariant of the probe that looks across cycles: it is never within 0.5 m of
    the pole for more than ten cycles in a row (it is, on every approach)."""

    def __init__(self) -> None:
        self.near = 0

    def __call__(self, cycle: Cycle) -> None:
        self.near = self.near + 1 if cycle.robot_state.distance < 0.5 else 0
        assert self.near <= LINGER, f"{self.near} cycles within 0.5 m of the pole"


LINGER = 10
"""The cycles in a row :class:`NeverLingers` lets the probe stay near the pole."""


def never_negative(cycle: Cycle) -> None:
    """An invariant of the probe that every recording of it keeps, and noise on its
    distance may not."""
    assert cycle.robot_state.distance >= 0, f"a distance of {cycle.robot_state.distance} m"


class Headway:
    """Keeps its distance to what is ahead: it accelerates in proportion to the gap past
    a headway, so that its one output takes another value in every cycle."""

    name = "headway"

    def __init__(self, gain: float) -> None:
        self.state: BehaviorState = "following"
        self.gain = gain

    def step(self, rs: Probe, ctx: Context) -> Outputs:
        return {"accel": self.gain * (rs.distance - 0.3)}


def headway_system() -> PriorityArbiter[Probe]:
    """A car-follower with one tuned constant, the gain of its headway control."""
    return PriorityArbiter([Headway(0.5)], robot_state=Probe)


def headway_system_retuned() -> PriorityArbiter[Probe]:
    """The car-follower, its gain retuned by 5 %: its output differs in every cycle."""
    return PriorityArbiter([Headway(0.525)], robot_state=Probe)


def record_headway(path: Path, cycles: int) -> Path:
    """Record ``cycles`` cycles of the car-follower behind a vehicle whose distance
    wanders, never repeating, and return the log."""
    with Recorder(path, headway_system(), seed=3, software="test") as recorder:
        for cycle in range(cycles):
            recorder.step(PERIOD_NS, Probe(distance=1.0 + 0.5 * math.sin(cycle / 37) + cycle / 5e3))
    return path
