"""ROS 2 bags built by the tests with rosbags, and the perception steps that read them.

:func:`write_bag` writes a bag in ``tmp_path`` with a message type of its own,
``my_robot_msgs/msg/Sonar`` (registered from its ``.msg`` definition, as a robot
package would ship it), beside a standard one (``std_msgs/msg/Float64``), a clock
topic and ``/rosout`` (``rcl_interfaces/msg/Log``, a type with constants). The probe
system of ``conftest`` runs on what :func:`perceive` folds from them: the sonar's range
is the distance, the last speed the reading. Specs and ``--perception`` name the
perception steps as ``tests.bags:FACTORY``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from ruamel.yaml import YAML

from beatlog.model.inbox import Sample
from beatlog.model.perception import Perception
from tests.conftest import Probe, distances

SONAR = "my_robot_msgs/msg/Sonar"
SONAR_MSG = """\
std_msgs/Header header
float32 range
uint8[] echo
float64[3] mount
string label
"""
SPEED = "std_msgs/msg/Float64"
SONAR_EVERY_NS = 10_000_000
SPEED_EVERY_NS = 50_000_000
TICK_EVERY_NS = 30_000_000
START_NS = 1_700_000_000_000_000_000
"""Log times are Unix time, as a robot's ROS clock gives them."""
LOG = "rcl_interfaces/msg/Log"
LOGS_FROM_NS = START_NS + 1_000_000_000
"""The first ``/rosout`` message comes a second after the bag's first message."""
LOG_EVERY_NS = 100_000_000
LOG_STUB = "uint8 level"
"""The definition of ``rcl_interfaces/msg/Log`` that rosbag2's own ``talker`` test bags
carry: a stub, which the messages on ``/rosout`` do not fit."""


def write_bag(
    path: Path,
    *,
    storage: StoragePlugin = StoragePlugin.MCAP,
    sonars: int = 300,
    speeds: int = 60,
    ticks: int = 0,
    logs: int = 0,
    stub_log: bool = False,
) -> Path:
    """A bag of ``sonars`` sonar messages (ranges following ``distances``), ``speeds``
    speeds, ``ticks`` messages on ``/tick`` and ``logs`` on ``/rosout`` (whose type the
    bag defines by :data:`LOG_STUB` with ``stub_log``); returns its folder."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(SONAR_MSG, SONAR))
    sonar, header, stamp = (
        store.types[SONAR],
        store.types["std_msgs/msg/Header"],
        store.types["builtin_interfaces/msg/Time"],
    )
    speed, log = store.types[SPEED], store.types[LOG]
    messages = [
        (
            "/sonar",
            START_NS + index * SONAR_EVERY_NS,
            sonar(
                header=header(stamp=stamp(sec=index, nanosec=0), frame_id="sonar_link"),
                range=distance,
                echo=np.array([index % 256, 7, 0], dtype=np.uint8),
                mount=np.array([0.1, 0.0, 0.2]),
                label="front",
            ),
            SONAR,
        )
        for index, distance in enumerate(distances(sonars))
    ]
    messages += [
        ("/speed", START_NS + 5 + index * SPEED_EVERY_NS, speed(data=0.1 * index), SPEED)
        for index in range(speeds)
    ]
    messages += [
        ("/tick", START_NS + (index + 1) * TICK_EVERY_NS, speed(data=float(index)), SPEED)
        for index in range(ticks)
    ]
    messages += [
        (
            "/rosout",
            LOGS_FROM_NS + index * LOG_EVERY_NS,
            log(
                stamp=stamp(sec=index, nanosec=0),
                level=20,  # INFO
                name="sonar_node",
                msg=f"echo {index}",
                file="sonar.cpp",
                function="read",
                line=42,
            ),
            LOG,
        )
        for index in range(logs)
    ]
    with Writer(path, version=Writer.VERSION_LATEST, storage_plugin=storage) as writer:
        connections = {
            topic: writer.add_connection(topic, kind, typestore=store)
            for topic, kind in (("/sonar", SONAR), ("/speed", SPEED), ("/tick", SPEED))
            if topic != "/tick" or ticks
        }
        if logs:
            connections["/rosout"] = (
                writer.add_connection("/rosout", LOG, msgdef=LOG_STUB, rihs01=stub_hash())
                if stub_log
                else writer.add_connection("/rosout", LOG, typestore=store)
            )
        for topic, time, message, kind in sorted(messages, key=lambda message: message[1]):
            writer.write(connections[topic], time, store.serialize_cdr(message, kind))
    return path


def stub_hash() -> str:
    """The type hash of ``rcl_interfaces/msg/Log`` as :data:`LOG_STUB` defines it."""
    stub = get_typestore(Stores.EMPTY)
    stub.register(get_types_from_msg(LOG_STUB, LOG))
    return stub.hash_rihs01(LOG)


def storage_file(bag: Path) -> Path:
    """The one storage file of the bag folder ``bag``, beside its ``metadata.yaml``."""
    [data] = [path for path in bag.iterdir() if path.name != "metadata.yaml"]
    return data


def edit_metadata(bag: Path, edit: Callable[[dict[str, Any]], object]) -> None:
    """Rewrite the ``metadata.yaml`` of the bag folder ``bag`` with ``edit`` applied to its
    ``rosbag2_bagfile_information``."""
    yaml = YAML(typ="safe")
    metadata = bag / "metadata.yaml"
    document = yaml.load(metadata.read_text())
    edit(document["rosbag2_bagfile_information"])
    with metadata.open("w") as file:
        yaml.dump(document, file)


TALKER_QOS = (
    "- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n  deadline:\n    sec: 0\n"
    "    nsec: 0\n  lifespan:\n    sec: 0\n    nsec: 0\n  liveliness: 1\n"
    "  liveliness_lease_duration:\n    sec: 0\n    nsec: 0\n"
    "  avoid_ros_namespace_conventions: false"
)
"""The offered QoS that rosbag2's own ``talker`` test bags name in their metadata.yaml."""


def name_other_qos(bag: Path) -> None:
    """Make the metadata.yaml of ``bag`` name QoS its storage file does not hold, as that
    of rosbag2's own ``talker`` test bags does: rosbags then matches none of its messages."""

    def edit(information: dict[str, Any]) -> None:
        for topic in information["topics_with_message_count"]:
            topic["topic_metadata"]["offered_qos_profiles"] = TALKER_QOS

    edit_metadata(bag, edit)


def flip_bit(path: Path, bit: int) -> None:
    """Flip bit ``bit`` of the file at ``path`` (bit 0 is the lowest of its first byte)."""
    data = bytearray(path.read_bytes())
    data[bit // 8] ^= 1 << (bit % 8)
    path.write_bytes(bytes(data))


def perceive(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
    """The last sonar range is the distance, the last speed the reading."""
    state = Probe() if previous is None else previous
    for sample in samples:
        if sample.sensor == "/sonar":
            state = Probe(distance=sample.value["range"], reading=state.reading)
        elif sample.sensor == "/speed":
            state = Probe(distance=state.distance, reading=sample.value["data"])
    return state


def perception() -> Perception:
    return perceive


def long_range_perception() -> Perception:
    """A perception change: ranges from 0.8 on are read 10 % long."""

    def long_range(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
        state = perceive(previous, samples)
        distance = state.distance
        return Probe(
            distance=distance * 1.1 if distance >= 0.8 else distance, reading=state.reading
        )

    return long_range


def checking_perception() -> Perception:
    """The recorded perception, failing loudly unless each sonar sample is the message as
    plain data: a dict of its fields, the header nested, byte arrays as bytes."""

    def checking(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
        for sample in samples:
            if sample.sensor == "/sonar":
                value = sample.value
                assert value["header"]["frame_id"] == "sonar_link", value
                assert isinstance(value["echo"], bytes), value
                assert value["mount"] == [0.1, 0.0, 0.2], value
                assert value["label"] == "front", value
        return perceive(previous, samples)

    return checking


def broken_perception() -> Perception:
    """A perception step that fails once the sonar sees something close."""

    def broken(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
        state = perceive(previous, samples)
        if state.distance < 0.2:
            raise ValueError("sonar blinded")
        return state

    return broken


def wrong_perception() -> Perception:
    """A perception step that builds a dict where the system wants a Probe."""

    def wrong(previous: object, samples: Sequence[Sample]) -> dict[str, float]:
        return {"distance": 1.0}

    return wrong
