"""The session log's records: what a ``.beatlog`` file holds and how each is encoded.

A session log is an MCAP file (profile ``beatlog``) with three channels, all
msgpack-encoded with msgspec (``docs/format.md`` is the full specification):

- ``/beatlog/header``: one :class:`SessionHeader`, the first message.
- ``/beatlog/cycles``: :class:`ColumnBatch` messages (format 3: robot states stored by
  field, :mod:`beatlog.log.columns`), :class:`CycleBatch` messages in format 2, a bare
  list of :class:`CycleRecord` in format 1; one record per heartbeat, in order.
- ``/beatlog/end``: one :class:`SessionEnd`, written when the recording closes.

Each cycle keeps its parts as raw msgpack: replay compares them byte for byte.
"""

from __future__ import annotations

import re
from typing import Annotated, Any, NamedTuple

import msgspec

from beatlog.log.limits import (
    MAX_BEHAVIORS,
    MAX_FIELDS,
    MAX_NAME_LENGTH,
    MAX_SETUP_DRAWS,
    MAX_TEXT_LENGTH,
)

__all__ = [
    "COLUMNS_SINCE",
    "CYCLES_TOPIC",
    "CYCLE_BATCH_SINCE",
    "DECODE_ERRORS",
    "EMPTY_LIST",
    "EMPTY_MAP",
    "END_TOPIC",
    "FORMAT_VERSION",
    "HEADER_TOPIC",
    "MESSAGE_ENCODING",
    "OLDEST_FORMAT_VERSION",
    "PROFILE",
    "PYTHON_VERSION_SINCE",
    "SCHEMA_ENCODING",
    "SETUP_DRAWS_SINCE",
    "ColumnBatch",
    "CycleBatch",
    "CycleRecord",
    "Draw",
    "LoggedStateChange",
    "SessionEnd",
    "SessionHeader",
    "cycles_record",
    "payload_encoder",
    "samples_shape",
    "schema_name",
]

FORMAT_VERSION = 5
"""Raised whenever a change would make older readers misread a log."""
OLDEST_FORMAT_VERSION = 1
"""The oldest format version this beatlog still reads (and replays)."""
CYCLE_BATCH_SINCE = 2
"""From this version on, each cycles message is a :class:`CycleBatch` with its first cycle."""
COLUMNS_SINCE = 3
"""From this version on, each cycles message is a :class:`ColumnBatch`: robot states by field."""
SETUP_DRAWS_SINCE = 4
"""From this version on, the header holds the draws the system made while it was built
(:attr:`SessionHeader.setup_draws`)."""
PYTHON_VERSION_SINCE = 5
"""From this version on, the header names the Python the session was recorded under
(:attr:`SessionHeader.python_version`)."""

PROFILE = "beatlog"
MESSAGE_ENCODING = "msgpack"
SCHEMA_ENCODING = "jsonschema"
HEADER_TOPIC = "/beatlog/header"
CYCLES_TOPIC = "/beatlog/cycles"
END_TOPIC = "/beatlog/end"

DECODE_ERRORS = (msgspec.DecodeError, RecursionError)
"""What decoding a damaged or hostile payload may raise (msgpack nested too deep included)."""

EMPTY_LIST = msgspec.Raw(b"\x90")
"""An empty msgpack array: no state changes, no draws, no samples."""
EMPTY_MAP = msgspec.Raw(b"\x80")
"""An empty msgpack map: no outputs."""


def _encode_array_like(obj: Any) -> Any:
    """Encode numpy scalars and arrays that behaviors may put into states or outputs,
    and subclasses of ``float``, ``int`` and ``str`` (a unit's float) as their base."""
    tolist = getattr(obj, "tolist", None)
    if tolist is not None:
        return tolist()
    for plain in (float, int, str):
        if isinstance(obj, plain):
            return plain(obj)
    raise TypeError(f"cannot record a value of type {type(obj).__name__}")


def payload_encoder() -> msgspec.msgpack.Encoder:
    """The one msgpack encoder for log payloads; replay encodes with it too, to compare bytes."""
    return msgspec.msgpack.Encoder(enc_hook=_encode_array_like)


_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")
Name = Annotated[str, msgspec.Meta(max_length=MAX_NAME_LENGTH)]
Text = Annotated[str, msgspec.Meta(max_length=MAX_TEXT_LENGTH)]


class SessionHeader(msgspec.Struct, kw_only=True):
    """Describes a session log; enough to read it without the code that wrote it.

    Every string and list has a bound (:mod:`beatlog.log.limits`) checked on reading.
    """

    format_version: Annotated[int, msgspec.Meta(ge=OLDEST_FORMAT_VERSION)]
    beatlog_version: Name
    robot_id: Name
    software_version: Name
    system: Text
    """The ``module:factory`` the session was recorded with; only a name: a replay
    imports it only where the user's project vouches for it (:mod:`beatlog.project.config`)."""
    period_ns: Annotated[int, msgspec.Meta(gt=0)]
    start_time_ns: Annotated[int, msgspec.Meta(ge=0, le=2**63 - 1)]
    """Wall-clock start of the recording (Unix ns); never used by replay."""
    robot_state_type: Text
    robot_state_schema: dict[str, Any]
    behaviors: Annotated[list[Name], msgspec.Meta(max_length=MAX_BEHAVIORS)]
    """The behavior catalogue; a behavior's id in cycle records is its index here."""
    random_seed: int | None = None
    samples_logged: bool = False
    flush_interval_ns: Annotated[int, msgspec.Meta(gt=0)] = 1_000_000_000
    initial_states: Annotated[list[Any], msgspec.Meta(max_length=MAX_BEHAVIORS)] = []
    """Each behavior's state before cycle 0, in catalogue order; empty in logs written
    before beatlog recorded it (a reader then knows a state only from its first change)."""
    state_fields: Annotated[list[Name], msgspec.Meta(max_length=MAX_FIELDS)] = []
    """The robot state's fields as its cycles encode them, in order (format 3): where the
    header names them, batches store robot states by field, and a batch of states of
    exactly these fields names none (:class:`ColumnBatch`)."""
    setup_draws: (
        Annotated[list[Draw], msgspec.Meta(max_length=MAX_SETUP_DRAWS)] | msgspec.UnsetType
    ) = msgspec.UNSET
    """The random numbers the system drew while its factory built it, before cycle 0
    (format 4), each the system's (actor -1): replay builds the system with them. Unset
    (and not written) where it drew none, so a header without them has the bytes of
    format 3; :meth:`drawn_at_setup` reads them either way."""
    python_version: Name | msgspec.UnsetType = msgspec.UNSET
    """The Python the session was recorded under, e.g. ``3.12.1`` (format 5): a float
    ``sum()``, for one, adds otherwise from 3.12 on, so a replay under another minor
    version may diverge. Unset in older logs."""

    def problem(self) -> str | None:
        """What makes this header unreadable beyond its field bounds, or None."""
        named = {
            "robot_id": self.robot_id,
            "software_version": self.software_version,
            "beatlog_version": self.beatlog_version,
            "system": self.system,
            "robot_state_type": self.robot_state_type,
            "python_version": self.recorded_python() or "",
            **{f"behavior {index}": name for index, name in enumerate(self.behaviors)},
        }
        for field, name in named.items():
            if _CONTROL.search(name):  # printed by every report: it must not drive a terminal
                return f"{field} {name!r} holds control characters"
        if len(set(self.behaviors)) != len(self.behaviors):
            return "a behavior is named twice"
        if len(set(self.state_fields)) != len(self.state_fields):
            return "a robot-state field is named twice"
        if self.initial_states and len(self.initial_states) != len(self.behaviors):
            return f"{len(self.initial_states)} initial states for {len(self.behaviors)} behaviors"
        setup_draws = self.drawn_at_setup()
        if setup_draws and self.format_version < SETUP_DRAWS_SINCE:
            return f"set-up draws in a log of format {self.format_version}"
        if self.recorded_python() is not None and self.format_version < PYTHON_VERSION_SINCE:
            return f"a Python version in a log of format {self.format_version}"
        for number, draw in enumerate(setup_draws, 1):
            if draw.actor != -1:
                return f"set-up draw {number} is behavior #{draw.actor}'s, not the system's"
        return None

    def drawn_at_setup(self) -> list[Draw]:
        """The set-up draws, in the order drawn; none where the header holds none."""
        return [] if isinstance(self.setup_draws, msgspec.UnsetType) else self.setup_draws

    def recorded_python(self) -> str | None:
        """The Python version the session was recorded under; None where unknown."""
        return None if isinstance(self.python_version, msgspec.UnsetType) else self.python_version

    def initial_states_by_name(self) -> dict[str, Any]:
        """The recorded state before cycle 0 of each behavior, by name (empty when unknown)."""
        return dict(zip(self.behaviors, self.initial_states, strict=False))


LoggedStateChange = tuple[int, Any, Any]
"""A behavior state change as a cycle's record logs it: (catalogue index, before, after);
``beatlog.StateChange`` names the behavior instead."""


class Draw(NamedTuple):
    """One random number drawn in a cycle: who drew it (a catalogue index, -1 for the
    system), what kind, the value, and the parameters asked for (empty in format-1
    logs, which recorded none)."""

    actor: int
    kind: str
    value: Any
    params: tuple[Any, ...] = ()

    def call(self) -> str:
        """The request as code, e.g. ``uniform(2.0, 5.0)``."""
        return f"{self.kind}({', '.join(map(repr, self.params))})"


class CycleRecord(msgspec.Struct, array_like=True):
    """One heartbeat t of the session log: SL_t = (HB_t, RS_t, BS_t, RN_t) plus outputs.

    ``state_changes`` is a list of ``[behavior index, before, after]``;
    ``random_numbers`` a list of ``[actor index, kind, value, params]``; ``outputs`` a
    map of output name to value; ``samples`` the raw sensor samples folded into
    ``robot_state`` when sample logging is on.
    """

    heartbeat_ns: Annotated[int, msgspec.Meta(ge=0)]
    robot_state: msgspec.Raw
    state_changes: msgspec.Raw
    random_numbers: msgspec.Raw
    outputs: msgspec.Raw
    samples: msgspec.Raw


class CycleBatch(msgspec.Struct, array_like=True):
    """One cycles message (format 2): consecutive cycles, starting at ``first_cycle``.

    The reader checks that each batch starts where the previous one ended, so a
    missing, repeated or reordered batch is an error, never a shorter replay.
    """

    first_cycle: Annotated[int, msgspec.Meta(ge=0)]
    cycles: list[CycleRecord]


class ColumnBatch(msgspec.Struct, array_like=True, omit_defaults=True):
    """One cycles message of format 3: robot states stored by field (``docs/format.md``)."""

    first_cycle: Annotated[int, msgspec.Meta(ge=0)]
    cycles: list[CycleRecord]
    """Each cycle's record; its ``robot_state`` nil where the batch stores them by field."""
    state_fields: Annotated[list[Name], msgspec.Meta(max_length=MAX_FIELDS)] | None = None
    """The field each robot-state column holds, in order; empty: the header's; None: the
    records hold the robot states, as in format 2, and there are no columns."""
    widths: Annotated[bytes, msgspec.Meta(max_length=MAX_FIELDS)] = b""
    """Each column's width, a byte each (:class:`~beatlog.log.columns.Column`)."""
    sizes: Annotated[bytes, msgspec.Meta(max_length=4 * MAX_FIELDS)] = b""
    """Each column's size in ``data``, 4 bytes each (little-endian)."""
    data: bytes = b""
    """The robot-state columns back to back."""


class SessionEnd(msgspec.Struct, kw_only=True):
    """Written when a recording closes cleanly; its absence means the log was cut off.

    The reader checks ``cycles`` and ``robot_time_ns`` against the cycles it read.
    """

    cycles: Annotated[int, msgspec.Meta(ge=0)]
    robot_time_ns: Annotated[int, msgspec.Meta(ge=0)]
    overruns: Annotated[int, msgspec.Meta(ge=0)] = 0
    error: Text | None = None
    """Why recording stopped early (e.g. disk full), if it did."""


class _AnySamples(msgspec.Struct, array_like=True, gc=False):
    """Any array: a cycle's ``samples`` decoded as this are checked to be an array, and
    skipped, not read."""


class _NoSamples(msgspec.Struct, array_like=True, forbid_unknown_fields=True, gc=False):
    """Only an empty array: the ``samples`` of a cycle in a log that logged none."""


def samples_shape(header: SessionHeader) -> type[msgspec.Struct]:
    """What a cycle's ``samples`` are decoded as to check them against the header without
    reading them: an empty array where it logged none, else an array (each sample is
    checked where samples are read: sensor-level replay)."""
    return _AnySamples if header.samples_logged else _NoSamples


def schema_name(record: type[msgspec.Struct]) -> str:
    """The MCAP schema name of a record type, e.g. ``beatlog.SessionHeader``."""
    return f"beatlog.{record.__name__}"


def cycles_record(version: int) -> type[msgspec.Struct]:
    """The record type a log of format ``version`` writes its cycles messages as (its
    cycles channel's schema is named after it)."""
    if version >= COLUMNS_SINCE:
        return ColumnBatch
    return CycleBatch if version >= CYCLE_BATCH_SINCE else CycleRecord
