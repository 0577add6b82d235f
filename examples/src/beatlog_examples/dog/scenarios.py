"""Scenario scripts: the human tester, so every test case can be re-recorded on demand.

A scenario says where the dog starts, how charged its battery is and what the tester
does when: place a box (somewhere, or right in front of the dog), touch its head,
back or chin (firmly or lightly), push it over, tip it over by hand, hold it, hold it
back, switch on a load that runs its battery down, swap its battery, or drive it with
the remote control (and release it, or let the link drop). A scenario can also have a
sensor driver boot late, as an IMU driver that starts after the control loop does. The
tester acts on the world or through the remote, never on the behaviors: the behaviors
learn of it only through their sensors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

from beatlog_examples.dog.world import DogWorld

__all__ = [
    "DEMO",
    "REMOTE_ACTIONS",
    "SUITE",
    "Event",
    "Scenario",
    "apply",
    "describe",
    "scenario",
]

REMOTE_RATE_HZ = 10.0
"""How often the remote-control client repeats its command."""
REMOTE_ACTIONS = frozenset({"drive", "drive_dropped"})
"""The actions a remote-control client carries out, not the tester's hands."""


class Event(NamedTuple):
    """One thing the tester does, ``at_s`` seconds into the session.

    Actions: ``place`` (box, x, y), ``place_ahead`` (box, metres ahead of the torso),
    ``remove`` (box), ``touch`` (part, seconds, and optionally how deep the hand
    presses, m), ``push`` (+1 left or -1 right), ``lean`` (+1 left or -1 right,
    degrees, seconds), ``hold`` (seconds), ``drag`` (seconds, N per m/s), ``drain``
    (a load's draw, battery fraction per second), ``swap`` (the new battery's charge,
    a fraction), and with the remote control ``drive`` (speed, turn rate, seconds; then
    a release) and ``drive_dropped`` (the same, but the link drops instead of
    releasing).
    """

    at_s: float
    action: str
    args: tuple[Any, ...] = ()


@dataclass(frozen=True)
class Scenario:
    """A recorded test case's set-up and script."""

    name: str
    purpose: str
    duration_s: float
    events: tuple[Event, ...] = ()
    start: tuple[float, float, float] = (1.0, 2.0, 0.0)
    """x, y (m) and heading (rad) of the dog at the start."""
    battery: float = 1.0
    tags: tuple[str, ...] = ()
    booting: tuple[tuple[str, float], ...] = ()
    """Sensor drivers that boot late: (sensor, seconds after the start); each publishes
    nothing before then."""

    def boot_s(self, sensor: str) -> float:
        """How long after the start the sensor's driver publishes its first sample."""
        return dict(self.booting).get(sensor, 0.0)

    def world(self) -> DogWorld:
        """A fresh world set up for this scenario."""
        x, y, heading = self.start
        return DogWorld(x=x, y=y, heading=heading, battery=self.battery)

    def procedure(self) -> list[str]:
        """The steps a person would follow to record this test case by hand."""
        x, y, heading = self.start
        steps = [
            f"Put the dog at ({x:g}, {y:g}) m facing {math.degrees(heading):.0f}°, "
            f"battery {self.battery * 100:g}%.",
            f"Start recording; the session lasts {self.duration_s:g} s.",
        ]
        steps += [
            f"The {sensor} driver boots {seconds:g} s after the start and publishes nothing before."
            for sensor, seconds in self.booting
        ]
        steps += [f"At {event.at_s:g} s: {describe(event)}." for event in self.events]
        return steps


def describe(event: Event) -> str:
    """What the tester does, in words."""
    action, args = event.action, event.args
    if action == "place":
        return f"place {args[0]} at ({args[1]:g}, {args[2]:g}) m"
    if action == "place_ahead":
        return f"place {args[0]} {args[1]:g} m in front of the dog"
    if action == "place_at_range":
        return f"place {args[0]} where the {args[1]} range finder reads {args[2]:g} m"
    if action == "remove":
        return f"take {args[0]} away"
    if action == "touch":
        press = f", pressing {args[2] * 1000:g} mm deep," if len(args) > 2 else ""
        return f"touch its {args[0]}{press} for {args[1]:g} s"
    if action == "push":
        return f"push it over to its {_side(args[0])}"
    if action == "lean":
        return f"tip it {args[1]:g}° to its {_side(args[0])} for {args[2]:g} s, then set it upright"
    if action == "hold":
        return f"hold it in place for {args[0]:g} s"
    if action == "drag":
        return f"hold it back by its harness for {args[0]:g} s ({args[1]:g} N per m/s)"
    if action == "drain":
        return f"switch on a load that draws {args[0]:.2%} of the charge per second"
    if action == "swap":
        return f"swap in a battery charged to {args[0]:.1%}"
    speed, turn, seconds = args
    ending = "let the link drop without a release" if action == "drive_dropped" else "release it"
    return (
        f"drive it with the remote control for {seconds:g} s "
        f"(speed {speed:g} m/s, turn {turn:g} rad/s), then {ending}"
    )


def _side(side: int) -> str:
    return "left" if side > 0 else "right"


def apply(world: DogWorld, event: Event) -> None:
    """Carry out an event that acts on the world (every action but the remote control's)."""
    action, args = event.action, event.args
    if action == "place":
        world.place(args[0], args[1], args[2])
    elif action == "place_ahead":
        x, y, heading = world.pose
        world.place(args[0], x + args[1] * math.cos(heading), y + args[1] * math.sin(heading))
    elif action == "place_at_range":
        world.place_at_range(*args)
    elif action == "remove":
        world.remove(args[0])
    elif action == "touch":
        world.touch(*args)
    elif action == "push":
        world.push(args[0])
    elif action == "lean":
        world.lean(*args)
    elif action == "hold":
        world.hold(args[0])
    elif action == "drag":
        world.drag(*args)
    elif action == "drain":
        world.drain(args[0])
    elif action == "swap":
        world.swap_battery(args[0])
    else:
        raise ValueError(f"{action!r} is not an action on the world")


def _touches(part: str, times: tuple[float, ...], seconds: float = 1.0) -> tuple[Event, ...]:
    return tuple(Event(at, "touch", (part, seconds)) for at in times)


def _lightly(part: str, at_s: float, press: float) -> tuple[Event, Event]:
    """A firm touch, then, once the dog lies or sits still, a light one ``press`` m deep."""
    return Event(at_s, "touch", (part, 1.0)), Event(at_s + 1.2, "touch", (part, 1.0, press))


def _at_range(at_s: float, box: str, finder: str, metres: float) -> Event:
    return Event(at_s, "place_at_range", (box, finder, metres))


NOSE_CONTACT = 0.37
"""A box this far ahead of the torso centre (m) rests against the dog's nose."""

SUITE = (
    Scenario(
        "walk-straight",
        "In an open stretch the dog wanders: it walks, veers at random and keeps clear "
        "of the walls at the far end.",
        40.0,
        start=(0.6, 2.0, 0.0),
        tags=("locomotion",),
    ),
    Scenario(
        "wander-arena",
        "A long walk round the arena with its pillar and crate: wandering, avoiding, "
        "following walls, and getting bored along the way.",
        150.0,
        start=(1.0, 1.0, 0.8),
        tags=("locomotion", "obstacles", "boredom"),
    ),
    Scenario(
        "avoid-box",
        "A box put in the dog's path is seen by the range finders and avoided.",
        40.0,
        (Event(2.0, "place_ahead", ("box1", 0.9)),),
        start=(0.6, 2.0, 0.0),
        tags=("obstacles",),
    ),
    Scenario(
        "avoid-boxes",
        "Boxes put in front of the walking dog three times; it turns away from each.",
        60.0,
        (
            Event(3.0, "place_ahead", ("box1", 0.8)),
            Event(15.0, "place_ahead", ("box2", 0.7)),
            Event(30.0, "place_ahead", ("box3", 0.8)),
            Event(45.0, "remove", ("box1",)),
        ),
        start=(1.0, 1.5, 0.5),
        tags=("obstacles",),
    ),
    Scenario(
        "wall-follow",
        "Started alongside the north wall, the dog follows it at a steady distance.",
        45.0,
        start=(0.7, 3.65, 0.0),
        tags=("locomotion", "obstacles"),
    ),
    Scenario(
        "escape-bump",
        "A box shoved against the dog's nose presses its nose sensor: it backs up and "
        "turns a random way.",
        35.0,
        (
            Event(4.0, "place_ahead", ("box1", NOSE_CONTACT)),
            Event(14.0, "place_ahead", ("box2", NOSE_CONTACT)),
            Event(24.0, "place_ahead", ("box3", NOSE_CONTACT)),
        ),
        start=(1.0, 2.0, 0.0),
        tags=("obstacles", "touch"),
    ),
    Scenario(
        "escape-stuck",
        "Held by the tester, the dog walks without getting anywhere; leg odometry says "
        "it is stuck and it escapes.",
        40.0,
        (Event(4.0, "hold", (6.0,)), Event(20.0, "hold", (6.0,))),
        start=(1.0, 2.0, 0.0),
        tags=("locomotion",),
    ),
    Scenario(
        "head-pat",
        "Patting the head makes the dog sit for a while, and happier.",
        35.0,
        _touches("head", (4.0, 14.0, 24.0)),
        tags=("touch",),
    ),
    Scenario(
        "back-touch",
        "Stroking the back makes the dog lie down for a few seconds.",
        30.0,
        _touches("back", (4.0, 16.0)),
        tags=("touch",),
    ),
    Scenario(
        "chin-touch",
        "Touching the chin makes the dog shake its head.",
        30.0,
        _touches("chin", (5.0, 15.0), 0.8),
        tags=("touch",),
    ),
    Scenario(
        "remote-drive",
        "Driven from another process over the remote control, the dog walks and turns "
        "as told, then goes back to its own behaviors.",
        35.0,
        (
            Event(3.0, "drive", (0.2, 0.0, 4.0)),
            Event(10.0, "drive", (0.0, 1.0, 3.0)),
            Event(16.0, "drive", (0.15, -0.6, 4.0)),
        ),
        start=(1.2, 2.0, 0.0),
        tags=("remote",),
    ),
    Scenario(
        "remote-into-wall",
        "Remote control overrides obstacle avoidance: driven into a wall it bumps, and "
        "once released it escapes and avoids.",
        30.0,
        (Event(3.0, "drive", (0.2, 0.0, 7.0)),),
        start=(3.0, 2.0, 0.0),
        tags=("remote", "obstacles"),
    ),
    Scenario(
        "push-over",
        "Pushed over, the dog's accelerometer tells it that it fell, and it gets up.",
        35.0,
        (Event(5.0, "push", (1,)), Event(20.0, "push", (-1,))),
        tags=("falls",),
    ),
    Scenario(
        "low-battery",
        "With its battery nearly flat the dog finds the charging pad by its beacon, lies "
        "down on it and charges.",
        120.0,
        start=(1.6, 2.6, 1.5),
        battery=0.21,
        tags=("battery",),
    ),
    Scenario(
        "boredom-sleep",
        "Left alone, the dog gets bored, lies down and falls asleep; a pat wakes it up.",
        100.0,
        _touches("head", (75.0,)),
        start=(1.5, 2.0, 0.0),
        tags=("boredom", "touch"),
    ),
    Scenario(
        "light-touch",
        "Light touches while it lies or sits read about the touch threshold (1 N) and "
        "fade below it as it settles. The battery reads about 30 %, where low charge "
        "starts to sadden it.",
        35.0,
        (
            *_lightly("back", 4.0, 0.0001),
            *_lightly("head", 11.0, 0.00012),
            *_lightly("back", 18.0, 0.00008),
            *_lightly("head", 25.0, 0.0001),
        ),
        battery=0.302,
        tags=("touch", "battery"),
    ),
    Scenario(
        "tip-over",
        "Tipped by hand to about 60° while it walks, then further and held: only a tilt "
        "past 60° that lasts 0.3 s is a fall, and then it gets up.",
        30.0,
        (
            Event(4.0, "lean", (1, 57.0, 4.0)),
            Event(13.0, "lean", (-1, 63.0, 3.0)),
            Event(22.0, "lean", (1, 70.0, 2.0)),
        ),
        tags=("falls",),
    ),
    Scenario(
        "held-back",
        "Held back by its harness, the dog walks on at about 2 cm/s, the speed below "
        "which leg odometry says it is stuck; when it stays below, it escapes.",
        35.0,
        (Event(4.0, "drag", (8.0, 450.0)), Event(20.0, "drag", (8.0, 480.0))),
        start=(1.0, 2.0, 0.0),
        tags=("locomotion",),
    ),
    Scenario(
        "remote-dropped",
        "The remote control's link drops without a release: the dog keeps the last "
        "command for a second, then goes back to its own behaviors.",
        30.0,
        (
            Event(3.0, "drive_dropped", (0.2, 0.0, 3.0)),
            Event(10.0, "drive_dropped", (0.0, 0.8, 2.0)),
            Event(17.0, "drive", (0.15, 0.3, 3.0)),
            Event(23.0, "drive_dropped", (0.1, -0.5, 2.0)),
        ),
        start=(1.2, 2.0, 0.0),
        tags=("remote",),
    ),
    Scenario(
        "bored-asleep-touch",
        "Left alone until it is bored and asleep, the dog wakes when its chin is touched "
        "and shakes its head; the touch cheers it up.",
        65.0,
        _touches("chin", (57.0,), 0.8),
        start=(1.5, 2.0, 0.0),
        tags=("boredom", "touch"),
    ),
    Scenario(
        "imu-late",
        "The IMU driver boots half a second after the control loop, so perception starts "
        "from the robot state's defaults. Then, three times, driven by the remote at 5 cm/s, the "
        "slowest drive that still counts as walking, it is held: its speed falls through "
        "2 cm/s, it is stuck, and it escapes once the remote lets go.",
        30.0,
        (
            Event(2.5, "drive", (0.05, 0.0, 6.5)),
            Event(4.5, "hold", (4.0,)),
            Event(11.0, "drive", (0.05, 0.0, 6.5)),
            Event(13.0, "hold", (4.0,)),
            Event(19.5, "drive", (0.05, 0.0, 6.5)),
            Event(21.5, "hold", (4.0,)),
        ),
        start=(1.0, 2.0, 0.0),
        booting=(("imu", 0.5),),
        tags=("locomotion", "remote"),
    ),
    Scenario(
        "slow-charge",
        "Lying on the pad, charging slowly with a load switched on, the dog watches boxes "
        "the tester sets where its range finders read just past 0.5, 0.6 and 0.8 m, the "
        "distances at which it starts and stops following a wall; a battery swapped in "
        "at 89.5 % charges through 90 %, and it gets up.",
        40.0,
        (
            Event(1.0, "drain", (0.0185,)),
            _at_range(2.5, "box2", "left", 0.508),
            _at_range(5.0, "box2", "left", 0.794),
            _at_range(10.5, "box2", "left", 0.45),
            _at_range(10.5, "box1", "front", 0.592),
            _at_range(13.5, "box2", "left", 0.794),
            Event(19.5, "remove", ("box1",)),
            Event(19.5, "remove", ("box2",)),
            _at_range(19.5, "box3", "right", 0.508),
            _at_range(23.0, "box3", "right", 0.794),
            Event(28.5, "remove", ("box3",)),
            _at_range(28.5, "box2", "left", 0.45),
            _at_range(28.5, "box1", "front", 0.592),
            Event(31.0, "swap", (0.895,)),
            _at_range(32.0, "box2", "left", 0.794),
            Event(33.5, "remove", ("box1",)),
            Event(33.5, "remove", ("box2",)),
        ),
        start=(0.8, 3.2, 0.0),
        battery=0.195,
        tags=("battery", "obstacles"),
    ),
)
"""The 22 test cases of the dog's suite."""

DEMO = Scenario(
    "demo",
    "A short session for the demo: a box in the way, a pat on the head and a push.",
    20.0,
    (
        Event(3.0, "place_ahead", ("box1", 0.8)),
        Event(9.0, "touch", ("head", 1.0)),
        Event(14.0, "push", (1,)),
    ),
    tags=("demo",),
)


def scenario(name: str) -> Scenario:
    """The suite's (or the demo's) scenario of that name."""
    for candidate in (*SUITE, DEMO):
        if candidate.name == name:
            return candidate
    names = ", ".join(s.name for s in SUITE)
    raise KeyError(f"no scenario named {name!r}; the suite has {names}")
