"""Reading a ROS bag with rosbags, trusted only as far as its metadata.

Every message counted on the topics imported must be read, at a log time within the
bag's span, and a topic's first message must deserialize, or the bag is refused with
a :class:`~beatlog.errors.BagError`. Messages come out as plain data, as replay decodes
them from a log; :mod:`beatlog.adapters.rosbag` folds them into heartbeats.
"""

from __future__ import annotations

import functools
from collections import Counter
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import fields, is_dataclass
from pathlib import Path, PurePath
from typing import TYPE_CHECKING, Any

from beatlog.errors import BagError
from beatlog.log.files import irregular_file_problem
from beatlog.model.inbox import Sample

if TYPE_CHECKING:
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import Connection

__all__ = ["BagMessages", "open_bag"]

_TIME_SLACK_NS = 1_000_000_000
"""How far a message's log time may lie outside the bag's span as its metadata gives
it, at least (rosbag2 records messages that arrive out of order a little past it)."""

_BYTE_TYPES = frozenset({"|u1", "|i1"})
"""numpy dtypes of arrays imported as bytes: ROS ``uint8[]`` and ``int8[]`` are byte
buffers."""


@contextmanager
def open_bag(bag: Path) -> Iterator[AnyReader]:
    """The bag opened with rosbags; whatever rosbags refuses is a :class:`BagError`."""
    try:
        from rosbags.highlevel import AnyReader  # noqa: PLC0415 - optional
        from rosbags.typesys import Stores, get_typestore  # noqa: PLC0415
    except ModuleNotFoundError:
        raise BagError(
            bag, 'importing a ROS bag needs rosbags (pip install "beatlog[ros]")'
        ) from None
    if not bag.exists():
        raise BagError(bag, "no such bag")
    for path in _files(bag):
        problem = irregular_file_problem(path)
        if problem is not None:
            raise BagError(path, problem)
    try:
        reader = AnyReader([bag], default_typestore=get_typestore(Stores.LATEST))
        reader.open()
    except Exception as exc:  # rosbags parsing a foreign file raises anything
        raise BagError(bag, f"not a readable ROS bag: {_reason(exc)}") from None
    try:
        yield reader
    finally:
        reader.close()


def _files(bag: Path) -> Iterator[Path]:
    """The files rosbags opens to read ``bag``: the bag file itself, or a folder's
    ``metadata.yaml`` and the storage files it names, checked one by one as found."""
    if not bag.is_dir():
        yield bag
        return
    metadata = bag / "metadata.yaml"
    yield metadata
    from ruamel.yaml import YAML  # noqa: PLC0415 - rosbags' own YAML reader

    try:
        information = YAML(typ="safe").load(metadata.read_text())["rosbag2_bagfile_information"]
        names = list(information["relative_file_paths"])
    except Exception:
        return
    for name in names:
        if isinstance(name, str):
            yield bag / PurePath(name).name  # as rosbags finds them


def _reason(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


class BagMessages:
    """The messages of one bag on the topics imported, each checked against the bag's
    metadata: its counts, its span and its message definitions."""

    def __init__(self, bag: Path, reader: AnyReader) -> None:
        self.bag = bag
        self.reader = reader
        self.read = 0
        """Messages read as samples."""
        self.counted = {topic: info.msgcount for topic, info in reader.topics.items()}
        """The messages on each topic as the bag's metadata counts them."""
        self.topics: list[str] = []
        """The topics imported, once selected."""
        slack = max(reader.end_time - reader.start_time, _TIME_SLACK_NS)
        self.times = (reader.start_time - slack, reader.end_time + slack)
        """The log times a message may have, from and before: the bag's span and as much
        again each side."""

    def select(self, topics: Sequence[str], clock_topic: str | None) -> list[Connection]:
        """The connections of the topics asked for, each checked to be in the bag with
        messages and a known type."""
        total = sum(self.counted.values())
        if total != self.reader.message_count:
            raise BagError(
                self.bag,
                f"its metadata counts {self.reader.message_count} messages but {total} on "
                "its topics; the bag is damaged",
            )
        available = self.reader.topics
        wanted = list(topics) or sorted(available)
        for topic in [*wanted, *([clock_topic] if clock_topic else [])]:
            if topic not in available:
                names = ", ".join(sorted(available)) or "none"
                raise BagError(self.bag, f"no topic {topic!r} (the bag has: {names})")
        self.topics = sorted(set(wanted))
        selected = [c for c in self.reader.connections if c.topic in wanted]
        if not any(c.msgcount for c in selected):
            raise BagError(
                self.bag, f"its metadata counts no messages on {', '.join(wanted) or 'any topic'}"
            )
        known = self.reader.typestore.fielddefs
        for connection in selected:
            if connection.msgtype not in known:
                raise BagError(
                    self.bag,
                    f"topic {connection.topic!r}: the bag does not define message type "
                    f"{connection.msgtype} and it is no standard ROS 2 type"
                    + self.others(connection.topic),
                )
        return selected

    def others(self, topic: str) -> str:
        """How to import the other topics with messages, to end an error about ``topic``."""
        others = " ".join(
            f"--topic {other}" for other in self.topics if other != topic and self.counted[other]
        )
        return f"; import the others with {others}" if others else ""

    def ticks(self, clock_topic: str) -> list[int]:
        """The times of the clock topic's messages: one heartbeat each, equal times once."""
        clock = [c for c in self.reader.connections if c.topic == clock_topic]
        ticks = sorted({time for _, time, _ in self._messages(clock)})
        if len(ticks) < 2:
            raise BagError(
                self.bag,
                f"clock topic {clock_topic!r} has {len(ticks)} message times; "
                "heartbeats need at least 2",
            )
        return ticks

    def samples(self, connections: Sequence[Connection]) -> Iterator[Sample]:
        """Every message on ``connections`` in log-time order, as a sample of plain data."""
        for connection, time, message in self._messages(connections, deserialize=True):
            self.read += 1
            yield Sample(connection.topic, time, _plain(message))

    def _messages(
        self, connections: Sequence[Connection], *, deserialize: bool = False
    ) -> Iterator[tuple[Connection, int, object]]:
        """The messages on ``connections`` in log-time order, raw or deserialized."""
        reader = self.reader
        read: Counter[str] = Counter()
        try:
            for connection, time, raw in reader.messages(connections=connections):
                read[connection.topic] += 1
                self._check_time(connection.topic, time)
                first = read[connection.topic] == 1
                yield (
                    connection,
                    time,
                    self._deserialize(connection, raw, first=first) if deserialize else raw,
                )
        except BagError:
            raise
        except Exception as exc:  # rosbags reading a damaged file raises anything
            raise BagError(self.bag, f"damaged: {_reason(exc)}") from None
        counted = {connection.topic: self.counted[connection.topic] for connection in connections}
        differ = [
            f"topic {topic}: {read[topic]} of {count}"
            for topic, count in sorted(counted.items())
            if read[topic] != count
        ]
        if differ:  # every message the metadata counts is read, and no more
            have, want = sum(read.values()), sum(counted.values())
            lead = (
                f"read {have} of the {want} messages its metadata counts"
                if have < want
                else f"read {have} messages where its metadata counts {want}"
            )
            raise BagError(self.bag, f"{lead} ({', '.join(differ)}); {self._damaged()}")

    def _deserialize(self, connection: Connection, raw: bytes, *, first: bool) -> object:
        """The message ``raw`` on ``connection``; a topic whose first message does not
        deserialize has a definition of its type that does not fit its messages."""
        try:
            return self.reader.deserialize(raw, connection.msgtype)
        except Exception:  # rosbags deserializing what does not fit raises anything
            if not first:
                raise  # messages before it fit: this one is damaged
        defined = any(other.msgdef.data for other in self.reader.connections)
        definition = (
            f"its message definition of {connection.msgtype} does not fit its messages "
            "(a stub definition?)"
            if defined
            else f"the standard definition of {connection.msgtype} does not fit its messages "
            "(the bag defines no types: a type of another ROS release?)"
        )
        raise BagError(
            self.bag, f"topic {connection.topic}: {definition}{self.others(connection.topic)}"
        )

    def _check_time(self, topic: str, time: object) -> None:
        """Refuse a log time that cannot be the message's: a damaged one, which would
        take an import by period hours of empty heartbeats to reach."""
        earliest, before = self.times
        if not isinstance(time, int):
            problem = f"a message on {topic} has a log time that is no integer ({time!r})"
        elif not earliest <= time < before:
            problem = (
                f"a message on {topic} has log time {time} ns, far outside the bag's span "
                f"as its metadata gives it ({self.reader.start_time} to "
                f"{self.reader.end_time} ns)"
            )
        else:
            return
        raise BagError(self.bag, f"{problem}; {self._damaged()}")

    def _damaged(self) -> str:
        """What may be wrong, to end an error about messages that do not fit the metadata."""
        if self.bag.is_dir():
            return "the bag is damaged, or its metadata.yaml does not match its storage files"
        return "the bag is damaged"


def _plain(value: Any) -> Any:
    """A deserialized ROS message as plain data: a dict of its fields (not its type's
    constants), numpy arrays as lists (byte arrays as bytes) and numpy scalars as
    numbers."""
    if value is None or isinstance(value, bool | int | float | str | bytes):
        return value
    if is_dataclass(value) and not isinstance(value, type):
        return {name: _plain(getattr(value, name)) for name in _field_names(type(value))}
    if isinstance(value, list | tuple):
        return [_plain(item) for item in value]
    if hasattr(value, "tolist"):  # numpy's arrays and scalars, known without importing it
        if value.ndim and value.dtype.str in _BYTE_TYPES:
            return value.tobytes()
        return value.tolist()
    raise TypeError(f"no plain data for a value of type {type(value).__name__}")


@functools.cache
def _field_names(message_class: type) -> tuple[str, ...]:
    """The fields of a rosbags message class: its dataclass fields less the ``ClassVar``
    ones, its type's constants and ``__msgtype__``, which rosbags' classes list as fields
    too (they import ``ClassVar`` only for type checking)."""
    return tuple(
        field.name for field in fields(message_class) if not str(field.type).startswith("ClassVar[")
    )
