"""A robot that brakes before a wall, with a ROS 2 bag of its sonar to import.

The bag is what a robot running ROS 2 would record: a message type of the robot's own,
``my_robot_msgs/msg/Sonar`` (from its ``.msg`` definition), published every 10 ms while
the robot closes in on a wall. ``beatlog import-bag`` turns it into a session log with
samples, :func:`perception` folds the sonar messages into the robot state, and
:func:`system` brakes when the wall is near::

    python -m beatlog_examples.corridor corridor     # writes the bag folder ./corridor
    beatlog import-bag corridor -o corridor.beatlog --spec corridor.dtc.toml \\
        --system beatlog_examples.corridor:system \\
        --perception beatlog_examples.corridor:perception
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from rosbags.rosbag2 import Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from beatlog import Context, Perception, PriorityArbiter, RobotState, Sample

__all__ = ["SONAR", "Ranges", "perception", "system", "write_bag"]

SONAR = "my_robot_msgs/msg/Sonar"
SONAR_MSG = "float32 range\nstring frame_id\n"
SONAR_EVERY_NS = 10_000_000
START_NS = 1_700_000_000_000_000_000
"""Log times are Unix time, as a robot's ROS clock gives them."""


class Ranges(RobotState, kw_only=True):
    """What the sonar says: the range ahead, in metres."""

    front: float = 10.0


class Brake:
    """On when the wall ahead is nearer than half a metre; it stops the robot."""

    name = "brake"
    state = "off"

    def step(self, rs: Ranges, ctx: Context) -> dict[str, float] | None:
        self.state = "on" if rs.front < 0.5 else "off"
        return {"speed": 0.0} if self.state == "on" else None


def system() -> PriorityArbiter[Ranges]:
    """Factory for ``--system beatlog_examples.corridor:system``."""
    return PriorityArbiter([Brake()], robot_state=Ranges)


def perceive(previous: Ranges | None, samples: Sequence[Sample]) -> Ranges:
    """The latest sonar range of the heartbeat, else the previous state."""
    state = previous or Ranges()
    for sample in samples:
        if sample.sensor == "/sonar":
            state = Ranges(front=sample.value["range"])
    return state


def perception() -> Perception:
    """Factory for ``--perception beatlog_examples.corridor:perception``."""
    return perceive


def write_bag(path: Path, *, messages: int = 200) -> Path:
    """Write a rosbag2 bag (MCAP storage) of the sonar closing in on a wall at ``path``."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(SONAR_MSG, SONAR))
    with Writer(path, version=Writer.VERSION_LATEST) as writer:
        sonar = writer.add_connection("/sonar", SONAR, typestore=store)
        for i in range(messages):
            message = store.types[SONAR](range=2.0 - i / 100, frame_id="front")
            stamp = START_NS + i * SONAR_EVERY_NS
            writer.write(sonar, stamp, store.serialize_cdr(message, SONAR))
    return path


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m beatlog_examples.corridor",
        description="Write a ROS 2 bag of a robot's sonar closing in on a wall.",
    )
    parser.add_argument("bag", type=Path, help="the bag folder to write (must not exist)")
    args = parser.parse_args(argv)
    if args.bag.exists():
        parser.exit(2, f"{args.bag}: exists already; give a new folder\n")
    try:
        print(f"wrote {write_bag(args.bag)}")
    except OSError as exc:
        parser.exit(2, f"{args.bag}: cannot write the bag: {exc.strerror}\n")


if __name__ == "__main__":
    main()
