"""The session log's records: what a ``.beatlog`` file holds and how each is encoded.

A session log is an MCAP file (profile ``beatlog``) with three channels, all
msgpack-encoded with msgspec:

- ``/beatlog/header``: one :class:`SessionHeader`, the first message.
- ``/beatlog/cycles``: batches of :class:`CycleRecord`, one per heartbeat, in order.
- ``/beatlog/end``: one :class:`SessionEnd`, written when the recording closes.

Each cycle keeps its parts as raw msgpack so the replay engine can compare behavior
state changes and outputs byte for byte, without decoding them, when they match.
"""

from __future__ import annotations

from typing import Any

import msgspec

__all__ = [
    "CHANNEL_TOPICS",
    "CYCLES_TOPIC",
    "EMPTY_LIST",
    "EMPTY_MAP",
    "END_TOPIC",
    "FORMAT_VERSION",
    "HEADER_TOPIC",
    "MESSAGE_ENCODING",
    "PROFILE",
    "CycleRecord",
    "SessionEnd",
    "SessionHeader",
    "payload_encoder",
]

FORMAT_VERSION = 1
"""Raised whenever a change would make older readers misread a log."""

PROFILE = "beatlog"
MESSAGE_ENCODING = "msgpack"
HEADER_TOPIC = "/beatlog/header"
CYCLES_TOPIC = "/beatlog/cycles"
END_TOPIC = "/beatlog/end"
CHANNEL_TOPICS = (HEADER_TOPIC, CYCLES_TOPIC, END_TOPIC)

EMPTY_LIST = msgspec.Raw(b"\x90")
"""An empty msgpack array: no state changes, no draws, no samples."""
EMPTY_MAP = msgspec.Raw(b"\x80")
"""An empty msgpack map: no outputs."""


def _encode_array_like(obj: Any) -> Any:
    """Encode numpy scalars and arrays that behaviors may put into states or outputs."""
    tolist = getattr(obj, "tolist", None)
    if tolist is None:
        raise TypeError(f"cannot record a value of type {type(obj).__name__}")
    return tolist()


def payload_encoder() -> msgspec.msgpack.Encoder:
    """The one msgpack encoder for log payloads; replay encodes with it too, to compare bytes."""
    return msgspec.msgpack.Encoder(enc_hook=_encode_array_like)


class SessionHeader(msgspec.Struct, kw_only=True):
    """Describes a session log; enough to read it without the code that wrote it."""

    format_version: int
    beatlog_version: str
    robot_id: str
    software_version: str
    system: str
    """The ``module:factory`` the session was recorded with (informational, never imported)."""
    period_ns: int
    start_time_ns: int
    """Wall-clock start of the recording (Unix ns); never used by replay."""
    robot_state_type: str
    robot_state_schema: dict[str, Any]
    behaviors: list[str]
    """The behavior catalogue; a behavior's id in cycle records is its index here."""
    random_seed: int | None = None
    samples_logged: bool = False
    flush_interval_ns: int = 1_000_000_000


class CycleRecord(msgspec.Struct, array_like=True):
    """One heartbeat t of the session log: SL_t = (HB_t, RS_t, BS_t, RN_t) plus outputs.

    ``state_changes`` is a list of ``[behavior index, before, after]``;
    ``random_numbers`` a list of ``[actor index, kind, value, params]``; ``outputs`` a
    map of output name to value; ``samples`` the raw sensor samples folded into
    ``robot_state`` when sample logging is on.
    """

    heartbeat_ns: int
    robot_state: msgspec.Raw
    state_changes: msgspec.Raw
    random_numbers: msgspec.Raw
    outputs: msgspec.Raw
    samples: msgspec.Raw


class SessionEnd(msgspec.Struct, kw_only=True):
    """Written when a recording closes cleanly; its absence means the log was cut off."""

    cycles: int
    robot_time_ns: int
    overruns: int = 0
    error: str | None = None
    """Why recording stopped early (e.g. disk full), if it did."""
