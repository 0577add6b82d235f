"""The MCAP export for Foxglove and Lichtblick: one JSON schema per channel, one JSON
message per cycle and channel (see :mod:`beatlog.adapters.export`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

from mcap.writer import Writer

from beatlog._version import __version__
from beatlog.adapters.export.fields import (
    BY_TYPE,
    GAP,
    NON_FINITE,
    Field,
    Kind,
    json_text,
    numbers_as_text,
    state_text,
    too_deep,
    typed_object,
    written_object,
    written_value,
)
from beatlog.adapters.export.reading import Cycle, Session, log_metadata, states_after
from beatlog.adapters.export.schemas import (
    BEHAVIOR_SCHEMA,
    DIVERGENCE_SCHEMA,
    FRAME_TRANSFORM_SCHEMA,
    HEARTBEAT_SCHEMA,
    LOG_SCHEMA,
    RANDOM_SCHEMA,
    outputs_schema,
    robot_state_schema,
    sample_schema,
)
from beatlog.errors import CorruptLogError, ExportError
from beatlog.replaying.verdict import Divergence, ReplayResult, StateChange

__all__ = ["write_mcap"]


_POSE_TOPIC = "/tf"
_POSE_FRAMES = ("odom", "base_link")
"""The frames of the robot's pose: the fixed frame it moves in, and the robot's own."""


# MCAP: messages


class _McapChannels:
    """Registers the export's schemas and channels and writes JSON messages to them."""

    def __init__(self, writer: Writer, log: Path, start_ns: int) -> None:
        self._writer = writer
        self._log = log
        self._start_ns = start_ns
        self._schemas: dict[str, int] = {}

    def add(self, topic: str, name: str, schema: Mapping[str, Any]) -> int:
        if name not in self._schemas:
            data = json_text(schema, self._log, f"the schema of {topic}")
            self._schemas[name] = self._writer.register_schema(name, "jsonschema", data)
        return int(self._writer.register_channel(topic, "json", self._schemas[name]))

    def stamp(self, cycle: Cycle) -> int:
        """The log time of a cycle's messages: the recording's start plus its robot time."""
        time_ns = self._start_ns + cycle.time_ns
        if time_ns > _MAX_LOG_TIME_NS:
            raise CorruptLogError(
                self._log, f"cycle {cycle.number} ends past the latest time MCAP can stamp"
            )
        return time_ns

    def write(self, channel: int, cycle: Cycle, message: Any, what: str) -> None:
        """Write ``message`` stamped with the cycle's log time and numbered with the cycle."""
        data = json_text(message, self._log, f"the {what} of cycle {cycle.number}")
        time_ns = self.stamp(cycle)
        self._writer.add_message(channel, time_ns, data, time_ns, sequence=cycle.number)


_MAX_LOG_TIME_NS = 2**64 - 1
_LOG_TIME = (
    "each message is stamped with the recording's start (start_time_ns, Unix ns) plus "
    "the robot time at the end of its cycle"
)


def _sample_topic(sensor: str) -> str:
    return f"/samples/{sensor.removeprefix('/')}"


class _Pose(NamedTuple):
    """Where the robot state holds the robot's pose: the object field holding ``x``, ``y``
    and the others (None: the robot state itself), the yaw's name, and whether it has a
    ``z`` (else 0)."""

    within: str | None
    yaw: str
    has_z: bool

    def of(self, state: Mapping[str, Any]) -> tuple[tuple[float, float, float], float] | None:
        """The position and yaw in ``state``; None when one is missing, NaN or infinite."""
        holder = state if self.within is None else state.get(self.within)
        if not isinstance(holder, dict):
            return None
        names = ("x", "y", self.yaw, "z") if self.has_z else ("x", "y", self.yaw)
        values = [holder.get(name) for name in names]
        numbers = [float(v) for v in values if isinstance(v, float | int) and math.isfinite(v)]
        if len(numbers) < len(names):
            return None
        x, y, yaw, *z = numbers
        return (x, y, z[0] if z else 0.0), yaw


_YAW_NAMES = ("heading", "yaw", "theta")


def _pose_of(robot_state: Field) -> _Pose | None:
    """The robot's pose: number fields ``x``, ``y`` (``z`` if there is one) and ``heading``,
    ``yaw`` or ``theta`` in the robot state, or else in its object field ``pose``."""
    pose = robot_state.fields.get("pose")
    holders = {None: robot_state.fields, "pose": {} if pose is None else pose.fields}
    for within, fields in holders.items():
        numbers = {name for name, field in fields.items() if field.kind is Kind.NUMBER}
        yaw = next((name for name in _YAW_NAMES if name in numbers), None)
        if yaw is not None and {"x", "y"} <= numbers:
            return _Pose(within, yaw, "z" in numbers)
    return None


def _robot_state_field(session: Session) -> Field:
    """The robot state's fields for the viewers: its arrays of numbers that hold a NaN or
    ±inf are arrays of number texts."""
    first = session.first
    if NON_FINITE in first.robot_state.fields:
        raise ExportError(
            f"{session.log}: robot-state field {NON_FINITE!r} has the name of the field "
            "that lists NaN and infinite values; export as a table instead"
        )
    return numbers_as_text(first.robot_state, first.non_finite_arrays)


def write_mcap(part: Path, session: Session, replayed: ReplayResult | None) -> None:
    log, header, first = session.log, session.header, session.first
    robot_state_field = _robot_state_field(session)
    outputs_field = typed_object(first.output_types)
    with part.open("wb") as file:
        writer = Writer(file)
        writer.start(profile="", library=f"beatlog {__version__}")
        writer.add_metadata("beatlog", {**log_metadata(session), "log_time": _LOG_TIME})
        channels = _McapChannels(writer, log, header.start_time_ns)
        robot_state_name = header.robot_state_type or "beatlog.RobotState"
        robot_state = channels.add(
            "/robot_state",
            robot_state_name,
            robot_state_schema(robot_state_name, robot_state_field),
        )
        behaviors = {
            name: channels.add(f"/behaviors/{name}", "beatlog.BehaviorState", BEHAVIOR_SCHEMA)
            for name in header.behaviors
        }
        state_changes = channels.add("/state_changes", "foxglove.Log", LOG_SCHEMA)
        outputs = channels.add("/outputs", "beatlog.Outputs", outputs_schema(outputs_field))
        random_numbers = channels.add("/random_numbers", "beatlog.RandomNumbers", RANDOM_SCHEMA)
        heartbeat = channels.add("/heartbeat", "beatlog.Heartbeat", HEARTBEAT_SCHEMA)
        samples = _SampleChannels(channels, first.samples, log)
        poses = _PoseChannel(channels, _pose_of(first.robot_state))
        divergence = None if replayed is None else replayed.divergence
        found = (
            None
            if divergence is None
            else channels.add("/divergence", "beatlog.Divergence", DIVERGENCE_SCHEMA)
        )
        states = dict(session.first.initial)
        write = channels.write
        for cycle in session.cycles:
            number = cycle.number
            non_finite: list[str] = []
            state = written_object(robot_state_field.fields, cycle.robot_state, "", non_finite)
            write(robot_state, cycle, _with_non_finite(state, non_finite), "robot state")
            interval_ns = cycle.heartbeat_ns
            heartbeat_message = {
                "cycle": number,
                "interval_ns": interval_ns,
                "interval_ms": interval_ns / 1e6,
            }
            write(heartbeat, cycle, heartbeat_message, "heartbeat")
            states_after(states, cycle.changes)
            if number == 0:
                for name, channel in behaviors.items():
                    message = {"cycle": 0, "state": state_text(states[name])}
                    write(channel, cycle, message, "behavior state")
            for change in cycle.changes:
                lane = behaviors.get(change.behavior)
                if number > 0 and lane is not None:
                    message = {"cycle": number, "state": state_text(change.after)}
                    write(lane, cycle, message, "behavior state")
                message = _log_message(channels.stamp(cycle), change)
                write(state_changes, cycle, message, "state change")
            non_finite = []
            written = written_object(outputs_field.fields, cycle.outputs, "outputs.", non_finite)
            message = _with_non_finite({"cycle": number, "outputs": written}, non_finite)
            write(outputs, cycle, message, "outputs")
            if cycle.draws:
                write(random_numbers, cycle, _draws_message(cycle, log), "random numbers")
            samples.write(cycle)
            poses.write(cycle)
            if found is not None and divergence is not None and divergence.cycle == number:
                message = _divergence_message(divergence, replayed.reproduce if replayed else "")
                write(found, cycle, message, "divergence")
        writer.finish()  # type: ignore[no-untyped-call]


class _SampleChannels:
    """A channel per sensor whose samples the log holds, each sample a message."""

    def __init__(
        self, channels: _McapChannels, samples: Mapping[str, Field | None], log: Path
    ) -> None:
        self._channels = channels
        self._log = log
        self._sensors = {}
        for sensor, field in samples.items():
            value = field or BY_TYPE["json"]
            topic = _sample_topic(sensor)
            name = f"beatlog.Sample{topic.removeprefix('/samples')}"
            self._sensors[sensor] = (
                channels.add(topic, name, sample_schema(sensor, value)),
                value,
            )

    def write(self, cycle: Cycle) -> None:
        for sample in cycle.samples:
            channel, field = self._sensors[sample.sensor]
            non_finite: list[str] = []
            try:
                value = written_value(field, sample.value, "value", non_finite)
            except RecursionError:
                raise too_deep(self._log, cycle.number) from None
            message = {"cycle": cycle.number, "stamp_ns": sample.stamp_ns}
            if value is not GAP:
                message["value"] = value
            self._channels.write(channel, cycle, _with_non_finite(message, non_finite), "samples")


class _PoseChannel:
    """The robot's pose each cycle, as a ``foxglove.FrameTransform`` for the 3D panel; no
    channel when the robot state holds no pose."""

    def __init__(self, channels: _McapChannels, pose: _Pose | None) -> None:
        self._channels = channels
        self._pose = (
            None
            if pose is None
            else (
                pose,
                channels.add(_POSE_TOPIC, "foxglove.FrameTransform", FRAME_TRANSFORM_SCHEMA),
            )
        )

    def write(self, cycle: Cycle) -> None:
        """The cycle's pose; none when the robot state holds a NaN or ±inf in it."""
        if self._pose is None:
            return
        pose, channel = self._pose
        placed = pose.of(cycle.robot_state)
        if placed is not None:
            position, yaw = placed
            message = _frame_transform(self._channels.stamp(cycle), position, yaw)
            self._channels.write(channel, cycle, message, "pose")


def _with_non_finite(message: dict[str, Any], non_finite: list[str]) -> dict[str, Any]:
    if non_finite:
        message[NON_FINITE] = non_finite
    return message


def _timestamp(time_ns: int) -> dict[str, int]:
    seconds, nanoseconds = divmod(time_ns, 1_000_000_000)
    return {"sec": seconds, "nsec": nanoseconds}


def _log_message(time_ns: int, change: StateChange) -> dict[str, Any]:
    """A behavior state change as a ``foxglove.Log`` message stamped ``time_ns`` (Unix
    ns), of level INFO (2)."""
    return {
        "timestamp": _timestamp(time_ns),
        "level": 2,
        "message": f"{change.behavior}: {change.before} -> {change.after}",
        "name": change.behavior,
        "file": "",
        "line": 0,
    }


def _frame_transform(
    time_ns: int, position: tuple[float, float, float], yaw: float
) -> dict[str, Any]:
    """A ``foxglove.FrameTransform`` placing the robot's frame at ``position`` in the fixed
    frame, turned ``yaw`` radians counter-clockwise about the z axis."""
    x, y, z = position
    parent, child = _POSE_FRAMES
    return {
        "timestamp": _timestamp(time_ns),
        "parent_frame_id": parent,
        "child_frame_id": child,
        "translation": {"x": x, "y": y, "z": z},
        "rotation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)},
    }


def _draws_message(cycle: Cycle, log: Path) -> dict[str, Any]:
    where = f"a random number of cycle {cycle.number}"
    return {
        "cycle": cycle.number,
        "draws": [
            {
                "actor": actor,
                "kind": draw.kind,
                "value": json_text(draw.value, log, where).decode(),
                "params": json_text(draw.params, log, where).decode(),
            }
            for actor, draw in cycle.draws
        ],
    }


def _divergence_message(divergence: Divergence, reproduce: str) -> dict[str, Any]:
    def changes(which: Sequence[StateChange]) -> list[dict[str, str]]:
        return [
            {
                "behavior": change.behavior,
                "before": state_text(change.before),
                "after": state_text(change.after),
            }
            for change in which
        ]

    return {
        "cycle": divergence.cycle,
        "kind": divergence.kind.value,
        "message": divergence.message,
        "behavior": divergence.behavior or "",
        "expected": changes(divergence.expected),
        "actual": changes(divergence.actual),
        "reproduce": reproduce,
    }
