"""The MCAP export for Foxglove and Lichtblick: one JSON schema per channel, one JSON
message per cycle and channel (see :mod:`beatlog.adapters.export`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import IO, Any

from mcap.writer import Writer

from beatlog._version import __version__
from beatlog.adapters.export.fields import (
    BY_TYPE,
    GAP,
    NON_FINITE,
    Field,
    Kind,
    json_text,
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
from beatlog.replay.verdict import Divergence, ReplayResult, StateChange

__all__ = ["write_mcap"]


_MAX_LOG_TIME_NS = 2**64 - 1
_LOG_TIME = (
    "each message is stamped with the recording's start (start_time_ns, Unix ns) plus "
    "the robot time at the end of its cycle"
)
_YAW_NAMES = ("heading", "yaw", "theta")


class _Mcap:
    """The export's channels, each with its schema, and the writing of each cycle's
    messages to them."""

    def __init__(self, writer: Writer, session: Session, replayed: ReplayResult | None) -> None:
        log, header, first = session.log, session.header, session.first
        if NON_FINITE in first.robot_state.fields:
            raise ExportError(
                f"{log}: robot-state field {NON_FINITE!r} has the name of the field "
                "that lists NaN and infinite values; export as a table instead"
            )
        self._writer, self._log, self._start_ns = writer, log, header.start_time_ns
        self._schemas: dict[str, int] = {}
        self.state_field = first.viewed_state
        self.outputs_field = typed_object(first.output_types)
        self.states = dict(first.initial)
        name = header.robot_state_type or "beatlog.RobotState"
        self.robot_state = self._add(
            "/robot_state", name, robot_state_schema(name, self.state_field)
        )
        self.behaviors = {
            name: self._add(f"/behaviors/{name}", "beatlog.BehaviorState", BEHAVIOR_SCHEMA)
            for name in header.behaviors
        }
        self.state_changes = self._add("/state_changes", "foxglove.Log", LOG_SCHEMA)
        self.outputs = self._add("/outputs", "beatlog.Outputs", outputs_schema(self.outputs_field))
        self.random_numbers = self._add("/random_numbers", "beatlog.RandomNumbers", RANDOM_SCHEMA)
        self.heartbeat = self._add("/heartbeat", "beatlog.Heartbeat", HEARTBEAT_SCHEMA)
        self.sensors = {}
        for sensor, field in first.samples.items():
            topic = f"/samples/{sensor.removeprefix('/')}"
            value = field or BY_TYPE["json"]
            name = f"beatlog.Sample{topic.removeprefix('/samples')}"
            self.sensors[sensor] = (
                self._add(topic, name, sample_schema(sensor, value)),
                value,
            )
        self.pose = _pose_of(first.robot_state)
        if self.pose is not None:
            self.tf = self._add("/tf", "foxglove.FrameTransform", FRAME_TRANSFORM_SCHEMA)
        self.divergence = None if replayed is None else replayed.divergence
        self.reproduce = "" if replayed is None else replayed.reproduce
        if self.divergence is not None:
            self.found = self._add("/divergence", "beatlog.Divergence", DIVERGENCE_SCHEMA)

    def _add(self, topic: str, name: str, schema: Mapping[str, Any]) -> int:
        if name not in self._schemas:
            data = json_text(schema, self._log, f"the schema of {topic}")
            self._schemas[name] = self._writer.register_schema(name, "jsonschema", data)
        return int(self._writer.register_channel(topic, "json", self._schemas[name]))

    def write(self, cycle: Cycle) -> None:
        """Every message of ``cycle``, each stamped with the recording's start plus the
        cycle's robot time and numbered with the cycle."""
        number = cycle.number
        time_ns = self._start_ns + cycle.time_ns
        if time_ns > _MAX_LOG_TIME_NS:
            raise CorruptLogError(
                self._log, f"cycle {number} ends past the latest time MCAP can stamp"
            )

        def write(channel: int, message: dict[str, Any], what: str, gaps: list[str]) -> None:
            if gaps:
                message[NON_FINITE] = gaps
            data = json_text(message, self._log, f"the {what} of cycle {number}")
            self._writer.add_message(channel, time_ns, data, time_ns, sequence=number)

        gaps: list[str] = []
        state = written_object(self.state_field.fields, cycle.robot_state, "", gaps)
        write(self.robot_state, state, "robot state", gaps)
        interval_ns = cycle.heartbeat_ns
        message: dict[str, Any] = {
            "cycle": number,
            "interval_ns": interval_ns,
            "interval_ms": interval_ns / 1e6,
        }
        write(self.heartbeat, message, "heartbeat", [])
        states_after(self.states, cycle.changes)
        if number == 0:
            for name, channel in self.behaviors.items():
                message = {"cycle": 0, "state": state_text(self.states[name])}
                write(channel, message, "behavior state", [])
        for change in cycle.changes:
            lane = self.behaviors.get(change.behavior)
            if number > 0 and lane is not None:
                message = {"cycle": number, "state": state_text(change.after)}
                write(lane, message, "behavior state", [])
            write(self.state_changes, _log_message(time_ns, change), "state change", [])
        gaps = []
        written = written_object(self.outputs_field.fields, cycle.outputs, "outputs.", gaps)
        write(self.outputs, {"cycle": number, "outputs": written}, "outputs", gaps)
        if cycle.draws:
            write(self.random_numbers, _draws_message(cycle, self._log), "random numbers", [])
        for sample in cycle.samples:
            channel, field = self.sensors[sample.sensor]
            gaps = []
            try:
                value = written_value(field, sample.value, "value", gaps)
            except RecursionError:
                raise too_deep(self._log, number) from None
            message = {"cycle": number, "stamp_ns": sample.stamp_ns}
            if value is not GAP:
                message["value"] = value
            write(channel, message, "samples", gaps)
        placed = None if self.pose is None else _placed(cycle.robot_state, *self.pose)
        if placed is not None:
            write(self.tf, _frame_transform(time_ns, *placed), "pose", [])
        if self.divergence is not None and self.divergence.cycle == number:
            message = _divergence_message(self.divergence, self.reproduce)
            write(self.found, message, "divergence", [])


def _pose_of(robot_state: Field) -> tuple[str | None, tuple[str, ...]] | None:
    """Where the robot state holds the robot's pose: the object field (None: the robot
    state itself) with number fields ``x``, ``y`` and ``heading``, ``yaw`` or ``theta``
    (then ``z`` if there is one), checked at the top level, then in ``pose``."""
    pose = robot_state.fields.get("pose")
    holders = {None: robot_state.fields, "pose": {} if pose is None else pose.fields}
    for within, fields in holders.items():
        numbers = {name for name, field in fields.items() if field.kind is Kind.NUMBER}
        yaw = next((name for name in _YAW_NAMES if name in numbers), None)
        if yaw is not None and {"x", "y"} <= numbers:
            return within, ("x", "y", yaw, *(("z",) if "z" in numbers else ()))
    return None


def _placed(
    state: Mapping[str, Any], within: str | None, names: Sequence[str]
) -> tuple[float, ...] | None:
    """The pose's numbers in ``state`` (``x``, ``y``, yaw, ``z``); None when one is
    missing, NaN or infinite."""
    holder = state if within is None else state.get(within)
    if not isinstance(holder, dict):
        return None
    values = [holder.get(name) for name in names]
    numbers = tuple(float(v) for v in values if isinstance(v, float | int) and math.isfinite(v))
    return numbers if len(numbers) == len(names) else None


def write_mcap(file: IO[bytes], session: Session, replayed: ReplayResult | None) -> None:
    writer = Writer(file)
    writer.start(profile="", library=f"beatlog {__version__}")
    writer.add_metadata("beatlog", {**log_metadata(session), "log_time": _LOG_TIME})
    mcap = _Mcap(writer, session, replayed)
    for cycle in session.cycles:
        try:
            mcap.write(cycle)
        except RecursionError:  # a value nested deeper than its JSON text can be written
            raise CorruptLogError(
                session.log, f"cycle {cycle.number} cannot be written as JSON: nested too deep"
            ) from None
    writer.finish()  # type: ignore[no-untyped-call]


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
    time_ns: int, x: float, y: float, yaw: float, z: float = 0.0
) -> dict[str, Any]:
    """A ``foxglove.FrameTransform`` placing the robot's frame (``base_link``) at ``x``,
    ``y``, ``z`` in the fixed frame (``odom``), turned ``yaw`` radians counter-clockwise
    about the z axis."""
    return {
        "timestamp": _timestamp(time_ns),
        "parent_frame_id": "odom",
        "child_frame_id": "base_link",
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
