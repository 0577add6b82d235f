"""Import a ROS bag as a session log with samples, so a bag becomes a DTC.

:func:`import_bag` reads a ROS 2 bag (MCAP or sqlite3 storage, or a ROS 1 bag) with
`rosbags <https://gitlab.com/ternaris/rosbags>`_, no ROS install needed
(``pip install "beatlog[ros]"``). Message types come from the bag itself where it
carries their definitions (every MCAP bag and sqlite3 bags from Iron on), so a
message type beatlog has never seen imports; older bags fall back to the standard
types of the latest ROS 2 release.

Each message becomes a raw :class:`~beatlog.model.inbox.Sample` named by its topic,
stamped with its log time, holding the message as plain data: a message is a dict of
its fields (not its type's constants), arrays are lists, and byte arrays (``uint8[]``,
``int8[]``: images, point clouds) are bytes, exactly as replay decodes them from the
log. The messages are grouped into heartbeats, either fixed periods from the first
message imported, or the intervals between messages on a clock topic (the messages
up to and including each clock message make up that heartbeat; those after the last
one are left out). The log starts where its first heartbeat does (its header's
``start_time_ns``: that first message, or the first clock message), so the log's
robot time added to it is the bag's time, as an export stamps it. At each
heartbeat the user's perception step folds the samples into RS_t and the system runs
on it, recording BS_t, RN_t and outputs with the samples, as a robot recording with
``log_samples`` would. A DTC of the log replays at sensor level: a changed
perception step fails it with a PERCEPTION divergence, a changed system with the
behavior state changes it made.

A bag is trusted only as far as its metadata: every message it counts on the topics
imported must be read, at a log time within its span, or the import is refused as
damaged; nothing is written then. A topic whose first message does not deserialize
is refused as one whose message definition does not fit its messages (rosbag2's own
``talker`` test bags carry a stub definition of ``rcl_interfaces/msg/Log``).
"""

from __future__ import annotations

import functools
import itertools
import os
import statistics
from collections import Counter
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import fields, is_dataclass
from pathlib import Path, PurePath
from typing import TYPE_CHECKING, Any, NamedTuple

from beatlog.errors import (
    BagError,
    BeatlogError,
    LogError,
    LogExistsError,
    OptionError,
    SpecError,
)
from beatlog.files import irregular_file_problem, replacing
from beatlog.log.format import payload_encoder
from beatlog.log.limits import MAX_NAME_LENGTH
from beatlog.log.writer import MAX_CYCLE_BYTES
from beatlog.model.behavior import System
from beatlog.model.clock import DEFAULT_PERIOD_NS
from beatlog.model.inbox import Sample
from beatlog.model.perception import Perception
from beatlog.record.recorder import Recorder
from beatlog.suite.spec import spec_text
from beatlog.usercode import failure_site, load_perception, load_system, user_traceback

if TYPE_CHECKING:
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import Connection

__all__ = ["MAX_HEARTBEATS", "MAX_SAMPLE_BYTES", "BagImport", "import_bag"]

MAX_SAMPLE_BYTES = 1 << 20
"""The largest message imported, as logged: a camera image is left out with ``topics``."""
MAX_HEARTBEATS = 10_000_000
"""The most heartbeats of its period a bag imported by period may span: 83 hours of
the default 30 ms."""
_TIME_SLACK_NS = 1_000_000_000
"""How far a message's log time may lie outside the bag's span as its metadata gives
it, at least (rosbag2 records messages that arrive out of order a little past it)."""

_BYTE_TYPES = frozenset({"|u1", "|i1"})
"""numpy dtypes of arrays imported as bytes: ROS ``uint8[]`` and ``int8[]`` are byte
buffers."""


class BagImport(NamedTuple):
    """What importing a bag wrote."""

    log: Path
    spec: Path | None
    """The DTC spec written beside the log, if one was asked for."""
    cycles: int
    samples: int
    """Messages imported, one sample each."""
    topics: tuple[str, ...]
    """The topics imported, sorted."""
    robot_time_ns: int
    left_out: int
    """Messages after the last clock message, which no heartbeat takes."""

    def describe(self) -> str:
        """One line for the command: what was imported, and where to."""
        topics = f"{len(self.topics)} topic{'' if len(self.topics) == 1 else 's'}"
        line = (
            f"imported {self.samples} messages on {topics} into "
            f"{self.cycles} cycles ({self.robot_time_ns / 1e9:.2f} s) to {self.log}"
        )
        if self.left_out:
            line += f"; {self.left_out} messages after the last clock message left out"
        if self.spec is not None:
            line += f"; DTC spec {self.spec}"
        return line


def import_bag(
    bag: str | Path,
    output: str | Path,
    *,
    system: System | str,
    perception: Perception | str,
    period_ns: int | None = None,
    clock_topic: str | None = None,
    topics: Sequence[str] = (),
    spec: str | Path | None = None,
    seed: int | None = None,
    overwrite: bool = False,
) -> BagImport:
    """Import the ROS bag ``bag`` (a rosbag2 folder, its ``.mcap`` or ``.db3`` file, or a
    ROS 1 ``.bag``) as the session log ``output``, written whole or not at all.

    ``system`` and ``perception`` are objects or ``module:factory`` references.
    Heartbeats come every ``period_ns`` from the first message imported (30 ms when
    neither option is given) or at each message on ``clock_topic``. ``topics`` are the
    topics imported as samples (default: every topic). ``spec`` also writes a DTC spec
    there that replays the log at sensor level; it needs ``system`` and ``perception``
    as references. ``seed`` seeds the random numbers the behaviors draw (fresh when
    None).
    An existing log or spec is replaced only with ``overwrite``.

    :raises beatlog.errors.BagError: the bag is missing, damaged or not a regular file,
        holds no messages on the topics asked for, yields fewer or more messages than its
        metadata counts, a topic's message definition does not fit its messages, a
        message is too large, or the perception step or the system raised (the message
        names the cycle; the user's traceback is kept).
    :raises beatlog.errors.OptionError: both a period and a clock topic, or a period
        that is not positive.
    """
    bag, output = Path(bag), Path(output)
    if period_ns is not None and clock_topic is not None:
        raise OptionError("give a heartbeat period or a clock topic, not both")
    if period_ns is not None and period_ns <= 0:
        raise OptionError(f"the heartbeat period must be positive, got {period_ns} ns")
    spec_path = None if spec is None else Path(spec)
    if spec_path is not None and not (isinstance(system, str) and isinstance(perception, str)):
        raise OptionError("a DTC spec names its system and perception: give module:factory")
    if output.exists() and not overwrite:
        raise LogExistsError(output)
    if spec_path is not None and spec_path.exists() and not overwrite:
        raise SpecError(spec_path, "already exists (overwrite=True replaces it)")
    built = load_system(system) if isinstance(system, str) else system
    perceive = load_perception(perception) if isinstance(perception, str) else perception
    if not output.parent.is_dir():
        raise LogError(output, f"cannot write: directory {output.parent} does not exist")
    if spec_path is not None and not spec_path.parent.is_dir():
        raise SpecError(spec_path, f"cannot write: directory {spec_path.parent} does not exist")
    with _open(bag) as reader:
        imported = _Import(bag, reader, built, perceive)
        selected = imported.select(topics, clock_topic)
        period, start, beats = imported.heartbeats(selected, period_ns, clock_topic)
        try:
            with replacing(output) as file:
                recorder = Recorder(
                    file,
                    built,
                    system_ref=system if isinstance(system, str) else "",
                    period_ns=period,
                    seed=seed,
                    log_samples=True,
                    robot_id=bag.name[:MAX_NAME_LENGTH] or "bag",
                    software=_software(reader),
                    start_time_ns=start,
                )
                with recorder:
                    imported.record(recorder, beats)
                if recorder.error is not None:
                    raise LogError(output, f"cannot write: {recorder.error}")
                if spec_path is not None:  # before the log is in place: both or neither
                    _write_spec(
                        spec_path, output, bag, system=str(system), perception=str(perception)
                    )
        except OSError as exc:
            raise LogError(output, f"cannot write: {exc.strerror or exc}") from None
    return BagImport(
        log=output,
        spec=spec_path,
        cycles=recorder.cycles,
        samples=imported.folded,
        topics=tuple(sorted({connection.topic for connection in selected})),
        robot_time_ns=recorder.robot_time_ns,
        left_out=imported.read - imported.folded,
    )


@contextmanager
def _open(bag: Path) -> Iterator[AnyReader]:
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


def _software(reader: AnyReader) -> str:
    """What recorded the bag, for the log's header."""
    if not reader.is2:
        return "ROS 1 bag"
    distros = {getattr(part, "ros_distro", None) for part in reader.readers}
    distro = distros.pop() if len(distros) == 1 else None
    return "ROS 2 bag" if not distro else f"ROS 2 bag ({distro})"[:MAX_NAME_LENGTH]


class _Import:
    """One bag being imported: its messages as samples, folded cycle by cycle."""

    def __init__(
        self, bag: Path, reader: AnyReader, system: System, perception: Perception
    ) -> None:
        self.bag = bag
        self.reader = reader
        self.system = system
        self.perception = perception
        self.read = 0
        """Messages read as samples."""
        self.folded = 0
        """Samples folded into a cycle."""
        self.counted = {topic: info.msgcount for topic, info in reader.topics.items()}
        """The messages on each topic as the bag's metadata counts them."""
        self.topics: list[str] = []
        """The topics imported, once selected."""
        slack = max(reader.end_time - reader.start_time, _TIME_SLACK_NS)
        self.times = (reader.start_time - slack, reader.end_time + slack)
        """The log times a message may have, from and before: the bag's span and as much
        again each side."""
        self._size = payload_encoder().encode

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
                    + self._others(connection.topic),
                )
        return selected

    def _others(self, topic: str) -> str:
        """The end of the message on a topic that cannot be imported: how to import the
        other topics with messages, if there are any."""
        others = " ".join(
            f"--topic {other}" for other in self.topics if other != topic and self.counted[other]
        )
        return f"; import the others with {others}" if others else ""

    def heartbeats(
        self, selected: Sequence[Connection], period_ns: int | None, clock_topic: str | None
    ) -> tuple[int, int, Iterator[tuple[int, list[Sample]]]]:
        """The period and start for the log's header, and each heartbeat's interval and
        samples. The first heartbeat starts at the first message imported, or at the
        first clock message: the log's start, from which its robot time is the bag's."""
        samples = self.samples(selected)
        if clock_topic is None:
            period = DEFAULT_PERIOD_NS if period_ns is None else period_ns
            span = self.reader.end_time - self.reader.start_time
            if span // period > MAX_HEARTBEATS:
                raise BagError(
                    self.bag,
                    f"its messages span {span / 1e9:.0f} s, {span // period} heartbeats of "
                    f"{period / 1e6:g} ms, more than an import writes ({MAX_HEARTBEATS}); "
                    "choose a longer heartbeat period or a clock topic",
                )
            first = next(samples)  # select() counted one: reading fails before it ends
            return (
                period,
                first.stamp_ns,
                _by_period(itertools.chain([first], samples), first.stamp_ns, period),
            )
        ticks = self._ticks(clock_topic)
        typical = statistics.median(after - before for before, after in itertools.pairwise(ticks))
        return max(1, int(typical)), ticks[0], _by_clock(samples, ticks)

    def _ticks(self, clock_topic: str) -> list[int]:
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
        """The messages on ``connections`` in log-time order, raw or deserialized; a bag
        rosbags cannot read on is a :class:`BagError`."""
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
        shortfall = _shortfall(read, counted)
        if shortfall is not None:
            raise BagError(self.bag, f"{shortfall}; {self._damaged()}")

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
            self.bag, f"topic {connection.topic}: {definition}{self._others(connection.topic)}"
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
        """The end of the message on messages that do not fit the bag's metadata: what
        may be wrong."""
        if self.bag.is_dir():
            return "the bag is damaged, or its metadata.yaml does not match its storage files"
        return "the bag is damaged"

    def record(self, recorder: Recorder, beats: Iterable[tuple[int, list[Sample]]]) -> None:
        """Fold each heartbeat's samples into RS_t and step the system on it."""
        state: Any = None
        robot_state = self.system.robot_state
        for cycle, (interval_ns, samples) in enumerate(beats):
            held = sum(self._checked_size(sample) for sample in samples)
            if held > MAX_CYCLE_BYTES // 2:
                raise BagError(
                    self.bag,
                    f"cycle {cycle} holds {held} bytes of messages, more than a cycle of a "
                    "log may; choose a shorter heartbeat period or fewer topics",
                )
            try:
                state = self.perception(state, samples)
            except BeatlogError:
                raise
            except (Exception, SystemExit) as exc:
                raise self._failed("the perception step", cycle, exc) from None
            if not isinstance(state, robot_state):
                raise BagError(
                    self.bag,
                    f"cycle {cycle}: the perception step built a {type(state).__name__}, "
                    f"not a {robot_state.__name__} (the system's robot state)",
                )
            try:
                recorder.step(interval_ns, state, samples)
            except BeatlogError:
                raise
            except (Exception, SystemExit) as exc:
                raise self._failed("the system", cycle, exc) from None
            self.folded += len(samples)

    def _checked_size(self, sample: Sample) -> int:
        """The bytes ``sample`` takes in the log, checked against :data:`MAX_SAMPLE_BYTES`."""
        size = len(self._size(sample))
        if size > MAX_SAMPLE_BYTES:
            raise BagError(
                self.bag,
                f"a message on {sample.sensor!r} is {size} bytes, more than a sample may "
                f"hold ({MAX_SAMPLE_BYTES})" + self._others(sample.sensor),
            )
        return size

    def _failed(self, who: str, cycle: int, exc: BaseException) -> BagError:
        message = " ".join(str(exc).split())
        site = failure_site(exc)
        return BagError(
            self.bag,
            f"cycle {cycle}: {who} raised {type(exc).__name__}"
            + (f": {message}" if message else "")
            + (f" ({site})" if site else ""),
            user_traceback=user_traceback(exc),
        )


def _shortfall(read: Counter[str], counted: dict[str, int]) -> str | None:
    """How the messages read on each topic differ from the counts of the bag's metadata,
    or None when every topic has its count."""
    differ = [
        f"topic {topic}: {read[topic]} of {count}"
        for topic, count in sorted(counted.items())
        if read[topic] != count
    ]
    if not differ:
        return None
    have, want = sum(read.values()), sum(counted.values())
    lead = (
        f"read {have} of the {want} messages its metadata counts"
        if have < want
        else f"read {have} messages where its metadata counts {want}"
    )
    return f"{lead} ({', '.join(differ)})"


def _by_period(
    samples: Iterable[Sample], start_ns: int, period_ns: int
) -> Iterator[tuple[int, list[Sample]]]:
    """Heartbeats every ``period_ns`` from ``start_ns``, each with the samples of its
    period, up to the period of the last sample."""
    end_ns = start_ns + period_ns
    pending: list[Sample] = []
    for sample in samples:
        while sample.stamp_ns >= end_ns:
            yield period_ns, pending
            pending = []
            end_ns += period_ns
        pending.append(sample)
    yield period_ns, pending


def _by_clock(
    samples: Iterable[Sample], ticks: Sequence[int]
) -> Iterator[tuple[int, list[Sample]]]:
    """A heartbeat at each tick after the first, with the samples up to and including it
    (the first takes those before the first tick too); later samples are dropped."""
    beat = 1
    pending: list[Sample] = []
    for sample in samples:
        while beat < len(ticks) and sample.stamp_ns > ticks[beat]:
            yield ticks[beat] - ticks[beat - 1], pending
            pending = []
            beat += 1
        if beat < len(ticks):
            pending.append(sample)
    for later in range(beat, len(ticks)):
        yield ticks[later] - ticks[later - 1], pending
        pending = []


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


def _write_spec(spec: Path, log: Path, bag: Path, *, system: str, perception: str) -> None:
    """A DTC spec for the imported log, replaying it at sensor level."""
    text = spec_text(
        name=log.name.removesuffix(".beatlog"),
        purpose=f"The system replays the ROS bag {bag.name} as imported.",
        procedure=[f"Imported from the ROS bag {bag.name} with beatlog import-bag."],
        log=os.path.relpath(log.resolve(), spec.resolve().parent),
        system=system,
        perception=perception,
    )
    try:
        with replacing(spec) as file:
            file.write(text.encode())
    except OSError as exc:
        raise SpecError(spec, f"cannot write: {exc.strerror}") from None
