"""Import a ROS bag as a session log with samples, so a bag becomes a DTC.

:func:`import_bag` reads a ROS 2 bag (MCAP or sqlite3 storage, or a ROS 1 bag) with
`rosbags <https://gitlab.com/ternaris/rosbags>`_, no ROS install needed
(``pip install "beatlog[ros]"``), with the message types the bag defines (else the
standard ones of the latest ROS 2 release). Each message becomes a
:class:`~beatlog.model.inbox.Sample` of plain data, as replay decodes it from the log
(:mod:`beatlog.adapters.bag`), named by its topic and stamped with its log time. The
messages are grouped into heartbeats, fixed periods from the first message imported
or the intervals between messages on a clock topic (each clock message closes a
heartbeat; messages after the last are left out), and the log starts with its first
heartbeat, so its robot time added to its start is the bag's time. The user's
perception step folds each heartbeat's samples into RS_t and the system steps on it,
recorded with the samples, so a DTC of the log replays at sensor level.
"""

from __future__ import annotations

import itertools
import os
import statistics
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from beatlog.adapters.bag import BagMessages, open_bag
from beatlog.errors import (
    BagError,
    BeatlogError,
    LogError,
    LogExistsError,
    OptionError,
    SpecError,
)
from beatlog.log.files import replacing
from beatlog.log.format import payload_encoder
from beatlog.log.limits import MAX_NAME_LENGTH
from beatlog.log.writer import MAX_CYCLE_BYTES
from beatlog.model.behavior import System
from beatlog.model.clock import DEFAULT_PERIOD_NS
from beatlog.model.inbox import Sample
from beatlog.model.perception import Perception
from beatlog.model.random import RecordingRandom
from beatlog.project.usercode import failure, load_perception, load_system, user_traceback
from beatlog.record.recorder import Recorder
from beatlog.suite.spec import spec_text

if TYPE_CHECKING:
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import Connection

__all__ = ["MAX_HEARTBEATS", "MAX_SAMPLE_BYTES", "BagImport", "import_bag"]

MAX_SAMPLE_BYTES = 1 << 20
"""The largest message imported, as logged: a camera image is left out with ``topics``."""
MAX_HEARTBEATS = 10_000_000
"""The most heartbeats of its period a bag imported by period may span: 83 hours of
the default 30 ms."""


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

    ``system`` and ``perception`` are objects or ``module:factory`` references (which a
    ``spec``, a DTC spec written beside the log, needs). Heartbeats come every
    ``period_ns`` (30 ms by default) or at each message on ``clock_topic``; ``topics``
    are imported as samples (default: all); ``seed`` seeds the behaviors' random numbers.

    :raises beatlog.errors.BagError: the bag is missing, damaged or foreign, or does
        not fit its metadata, a message is too large, or the user's code raised (named
        by cycle, its traceback kept).
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
    random = RecordingRandom(seed)  # a factory that takes it draws its set-up from it
    built = load_system(system, random=random) if isinstance(system, str) else system
    perceive = load_perception(perception) if isinstance(perception, str) else perception
    if not output.parent.is_dir():
        raise LogError(output, f"cannot write: directory {output.parent} does not exist")
    if spec_path is not None and not spec_path.parent.is_dir():
        raise SpecError(spec_path, f"cannot write: directory {spec_path.parent} does not exist")
    with open_bag(bag) as reader:
        messages = BagMessages(bag, reader)
        selected = messages.select(topics, clock_topic)
        period, start, beats = _heartbeats(messages, selected, period_ns, clock_topic)
        try:
            with replacing(output) as file:
                recorder = Recorder(
                    file,
                    built,
                    system_ref=system if isinstance(system, str) else "",
                    period_ns=period,
                    random=random,
                    log_samples=True,
                    robot_id=bag.name[:MAX_NAME_LENGTH] or "bag",
                    software=_software(reader),
                    start_time_ns=start,
                )
                with recorder:
                    folded = _record(messages, recorder, built, perceive, beats)
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
        samples=folded,
        topics=tuple(sorted({connection.topic for connection in selected})),
        robot_time_ns=recorder.robot_time_ns,
        left_out=messages.read - folded,
    )


def _software(reader: AnyReader) -> str:
    """What recorded the bag, for the log's header."""
    if not reader.is2:
        return "ROS 1 bag"
    distros = {getattr(part, "ros_distro", None) for part in reader.readers}
    distro = distros.pop() if len(distros) == 1 else None
    return "ROS 2 bag" if not distro else f"ROS 2 bag ({distro})"[:MAX_NAME_LENGTH]


def _heartbeats(
    bag: BagMessages,
    selected: Sequence[Connection],
    period_ns: int | None,
    clock_topic: str | None,
) -> tuple[int, int, Iterator[tuple[int, list[Sample]]]]:
    """The period and start for the log's header, and each heartbeat's interval and
    samples. The first heartbeat starts at the first message imported, or at the
    first clock message: the log's start, from which its robot time is the bag's."""
    samples = bag.samples(selected)
    if clock_topic is None:
        period = DEFAULT_PERIOD_NS if period_ns is None else period_ns
        span = bag.reader.end_time - bag.reader.start_time
        if span // period > MAX_HEARTBEATS:
            raise BagError(
                bag.bag,
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
    ticks = bag.ticks(clock_topic)
    typical = statistics.median(after - before for before, after in itertools.pairwise(ticks))
    return max(1, int(typical)), ticks[0], _by_clock(samples, ticks)


def _record(
    bag: BagMessages,
    recorder: Recorder,
    system: System,
    perception: Perception,
    beats: Iterable[tuple[int, list[Sample]]],
) -> int:
    """Fold each heartbeat's samples into RS_t and step the system on it; the samples
    folded."""
    state: Any = None
    folded = 0
    encode = payload_encoder().encode
    robot_state = system.robot_state
    for cycle, (interval_ns, samples) in enumerate(beats):
        held = 0
        for sample in samples:
            size = len(encode(sample))
            if size > MAX_SAMPLE_BYTES:
                raise BagError(
                    bag.bag,
                    f"a message on {sample.sensor!r} is {size} bytes, more than a sample "
                    f"may hold ({MAX_SAMPLE_BYTES})" + bag.others(sample.sensor),
                )
            held += size
        if held > MAX_CYCLE_BYTES // 2:
            raise BagError(
                bag.bag,
                f"cycle {cycle} holds {held} bytes of messages, more than a cycle of a "
                "log may; choose a shorter heartbeat period or fewer topics",
            )
        state = _run(bag.bag, "the perception step", cycle, perception, state, samples)
        if not isinstance(state, robot_state):
            raise BagError(
                bag.bag,
                f"cycle {cycle}: the perception step built a {type(state).__name__}, "
                f"not a {robot_state.__name__} (the system's robot state)",
            )
        _run(bag.bag, "the system", cycle, recorder.step, interval_ns, state, samples)
        folded += len(samples)
    return folded


def _run(bag: Path, who: str, cycle: int, call: Callable[..., Any], *args: Any) -> Any:
    """``call(*args)``; what the user's code (``who``) raises is a :class:`BagError`
    naming the cycle, with the user's traceback."""
    try:
        return call(*args)
    except BeatlogError:
        raise
    except (Exception, SystemExit) as exc:
        raise BagError(
            bag, f"cycle {cycle}: {who} {failure(exc)}", user_traceback=user_traceback(exc)
        ) from None


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
