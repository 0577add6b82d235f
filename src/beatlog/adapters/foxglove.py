"""Foxglove's well-known message schemas that ``beatlog export`` writes, and their messages.

The schemas are Foxglove's as published in foxglove/foxglove-sdk
(``schemas/jsonschema/*.json``): the name makes Foxglove's panels take the channel
(the Log panel a ``foxglove.Log``, the 3D panel a ``foxglove.FrameTransform``).
"""

from __future__ import annotations

import math
from typing import Any

__all__ = [
    "FRAME_TRANSFORM_SCHEMA",
    "LOG_INFO",
    "LOG_SCHEMA",
    "frame_transform",
    "log_message",
]


def _time(description: str) -> dict[str, Any]:
    return {
        "type": "object",
        "title": "time",
        "properties": {
            "sec": {"type": "integer", "minimum": 0},
            "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999},
        },
        "description": description,
    }


def _numbers(title: str, description: str, names: str, what: str) -> dict[str, Any]:
    return {
        "title": title,
        "description": description,
        "type": "object",
        "properties": {name: {"type": "number", "description": f"{name} {what}"} for name in names},
        "required": list(names),
    }


# foxglove.Log, except its level: there a oneOf of the level constants, which
# Lichtblick's parser rejects in releases that predate its enum support, here an integer.
LOG_SCHEMA = {
    "title": "Log",
    "description": "A log message",
    "type": "object",
    "properties": {
        "timestamp": _time("Timestamp of log message"),
        "level": {
            "type": "integer",
            "minimum": 0,
            "maximum": 5,
            "title": "LogLevel: Log level",
            "description": "Log level: 0 UNKNOWN, 1 DEBUG, 2 INFO, 3 WARNING, 4 ERROR, 5 FATAL",
        },
        "message": {"type": "string", "description": "Log message"},
        "name": {"type": "string", "description": "Process or node name"},
        "file": {"type": "string", "description": "Filename"},
        "line": {"type": "integer", "minimum": 0, "description": "Line number in the file"},
    },
}
LOG_INFO = 2
"""The ``level`` of an INFO message."""

FRAME_TRANSFORM_SCHEMA = {
    "title": "foxglove.FrameTransform",
    "description": "A transform between two reference frames in 3D space. The transform "
    "defines the position and orientation of a child frame within a parent frame. Foxglove "
    "applies the translation first and then the rotation.",
    "type": "object",
    "properties": {
        "timestamp": _time("Timestamp of transform"),
        "parent_frame_id": {"type": "string", "description": "Name of the parent frame"},
        "child_frame_id": {"type": "string", "description": "Name of the child frame"},
        "translation": _numbers(
            "foxglove.Vector3",
            "Translation component of the transform, representing the position of the "
            "child frame's origin in the parent frame.",
            "xyz",
            "coordinate length",
        ),
        "rotation": _numbers(
            "foxglove.Quaternion",
            "Rotation component of the transform, representing the orientation of the "
            "child frame in the parent frame",
            "xyzw",
            "value",
        ),
    },
    "required": ["timestamp", "parent_frame_id", "child_frame_id", "translation", "rotation"],
}


def _timestamp(time_ns: int) -> dict[str, int]:
    seconds, nanoseconds = divmod(time_ns, 1_000_000_000)
    return {"sec": seconds, "nsec": nanoseconds}


def log_message(time_ns: int, level: int, message: str, name: str) -> dict[str, Any]:
    """A ``foxglove.Log`` message stamped ``time_ns`` (Unix ns)."""
    return {
        "timestamp": _timestamp(time_ns),
        "level": level,
        "message": message,
        "name": name,
        "file": "",
        "line": 0,
    }


def frame_transform(
    time_ns: int, parent: str, child: str, position: tuple[float, float, float], yaw: float
) -> dict[str, Any]:
    """A ``foxglove.FrameTransform`` placing ``child`` at ``position`` in ``parent``,
    turned ``yaw`` radians counter-clockwise about the z axis."""
    x, y, z = position
    return {
        "timestamp": _timestamp(time_ns),
        "parent_frame_id": parent,
        "child_frame_id": child,
        "translation": {"x": x, "y": y, "z": z},
        "rotation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)},
    }
