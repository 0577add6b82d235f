"""The commands that write a new session log: ``beatlog record`` runs a robot in real
time and records its session; ``beatlog import-bag`` turns a ROS bag into a log,
replayable at sensor level. Neither overwrites a log without ``--force``."""

from __future__ import annotations

import argparse
import contextlib
import functools
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from beatlog.cli.common import (
    EXIT_FAILED,
    EXIT_OK,
    add_factory,
    add_invariants,
    positive_float,
    progress,
)
from beatlog.errors import BeatlogError, LogExistsError, OptionError

if TYPE_CHECKING:
    from rich.console import Console

    from beatlog.model.behavior import System

__all__ = ["add_arguments", "add_bag_arguments", "run", "run_bag"]


def add_arguments(record: argparse.ArgumentParser) -> None:
    """The options of ``beatlog record``."""
    add_factory(record, "--robot", "robot factory", required=True)
    record.add_argument("-o", "--output", required=True, type=Path, help="the .beatlog to write")
    record.add_argument(
        "--duration", type=positive_float, required=True, help="robot time to record (s)"
    )
    record.add_argument(
        "--period-ms",
        type=positive_float,
        default=30.0,
        help="heartbeat period in ms (default: %(default)s)",
    )
    record.add_argument("--seed", type=int, help="seed of the random source (default: fresh)")
    record.add_argument(
        "--robot-id", default="robot", help="name of the robot in the header (default: %(default)s)"
    )
    record.add_argument(
        "--system-ref",
        default="",
        metavar="MODULE:FACTORY",
        help="the system factory replay uses when given none, written into the header "
        "(checked before recording starts)",
    )
    record.add_argument("--log-samples", action="store_true", help="also log raw sensor samples")
    add_invariants(record, "as it is recorded, never stopping the robot")
    record.add_argument(
        "--flush-interval",
        type=positive_float,
        default=1.0,
        help="seconds of robot time between flushes to disk (default: %(default)s)",
    )
    record.add_argument("--fsync", action="store_true", help="fsync at every flush")
    record.add_argument("--force", action="store_true", help="overwrite an existing log")
    record.add_argument(
        "--no-certify",
        dest="certify",
        action="store_false",
        help="do not replay the log against a fresh system when the session ends (by "
        "default it is, and a log that does not replay fails the command, naming the "
        "first cycle that replays otherwise and the calls to blame)",
    )


def run(args: argparse.Namespace, console: Console) -> int:
    """Record until the duration is reached or Ctrl-C; the log is complete either way."""
    from beatlog.model.random import RandomSource, RecordingRandom
    from beatlog.project.usercode import load_robot, load_system
    from beatlog.record.recorder import Recorder
    from beatlog.report.counts import plural

    random = RecordingRandom(args.seed)
    robot = load_robot(args.robot, random=random)  # its system's set-up draws from it
    if args.system_ref:
        load_system(args.system_ref)  # replay will need it: a typo is found now, not then
    certify: Callable[[RandomSource], System] | None = None
    if args.certify:  # the system replay will use, else the recorded one from a new robot
        certify = (
            functools.partial(load_system, args.system_ref)
            if args.system_ref
            else lambda random: load_robot(args.robot, random=random).system
        )
    output: Path = args.output
    interrupted = False
    with _new_log(output, "; recordings are immutable"):
        recording = Recorder(
            output,
            robot.system,
            overwrite=args.force,
            robot_id=args.robot_id,
            system_ref=args.system_ref,
            period_ns=int(args.period_ms * 1e6),
            random=random,
            flush_interval_s=args.flush_interval,
            fsync=args.fsync,
            log_samples=args.log_samples,
            certify=certify,
            invariants=args.invariants,
        )
    with recording as recorder:
        try:
            with progress(console, "{task.completed} cycles") as bar:
                total = int(args.duration * 1e3 / args.period_ms)
                task = bar.add_task("recording", total=total)
                recorder.run(
                    robot,
                    duration_s=args.duration,
                    on_cycle=lambda cycles: bar.update(task, completed=cycles),
                )
        except KeyboardInterrupt:  # the log is closed as it is; say what it holds
            interrupted = True
    line = (
        f"recorded {plural(recorder.cycles, 'cycle')} ({recorder.robot_time_ns / 1e9:.2f} s, "
        f"{recorder.overruns} overruns) to {output}"
    )
    if recorder.error is not None:
        line += f"; {_write_failure(output, recorder.error)}"
    console.print(line, markup=False, highlight=False)
    certificate = recorder.certificate
    if certificate is not None:
        console.print(certificate.describe(), markup=False, highlight=False)
    violations = recorder.violations
    if violations:
        console.print(
            f"{plural(len(violations), 'invariant violation')} while recording "
            f"(each invariant's first is logged); the first: {violations[0]}",
            markup=False,
            highlight=False,
        )
    if interrupted:
        raise KeyboardInterrupt
    certified = certificate is None or certificate.ok
    return EXIT_OK if recorder.error is None and certified and not violations else EXIT_FAILED


def _write_failure(log: Path, error: str) -> str:
    """Where writing a log failed, as its first missing cycle read back from it."""
    from beatlog.analysis.summary import summarize

    try:
        kept = summarize(log).cycles
    except BeatlogError:
        return f"recording failed: {error} (the log cannot be read)"
    return f"recording failed at cycle {kept}: {error} (the log is valid up to there)"


@contextlib.contextmanager
def _new_log(output: Path, why: str = "") -> Iterator[None]:
    """Refuse a log to write before any work: its folder is missing, it is a folder, or
    it exists (without ``--force``: in one line that says ``why``)."""
    if not output.parent.is_dir():
        raise OptionError(f"{output}: directory {output.parent} does not exist")
    if output.is_dir():
        raise OptionError(f"{output}: is a directory")
    try:
        yield
    except LogExistsError:
        raise OptionError(f"{output}: already exists{why} (use --force)") from None


def add_bag_arguments(bag: argparse.ArgumentParser) -> None:
    """The options of ``beatlog import-bag``."""
    bag.add_argument(
        "bag", type=Path, help="the ROS 2 bag folder (mcap or sqlite3) or its file, or a ROS 1 .bag"
    )
    bag.add_argument("-o", "--output", required=True, type=Path, help="the .beatlog to write")
    add_factory(bag, "--system", "system factory", required=True)
    add_factory(
        bag,
        "--perception",
        "the perception step folding each heartbeat's messages into the robot state",
        required=True,
    )
    beats = bag.add_mutually_exclusive_group()
    beats.add_argument(
        "--period-ms",
        type=positive_float,
        help="a heartbeat every this many ms from the first message imported (default: 30)",
    )
    beats.add_argument(
        "--clock-topic",
        metavar="TOPIC",
        help="a heartbeat at each message on this topic instead",
    )
    bag.add_argument(
        "--topic",
        action="append",
        dest="topics",
        default=[],
        metavar="TOPIC",
        help="import this topic (repeatable; default: every topic)",
    )
    bag.add_argument(
        "--spec",
        type=Path,
        metavar="FILE",
        help="also write a DTC spec (*.dtc.toml) that replays the log at sensor level",
    )
    bag.add_argument("--seed", type=int, help="seed of the random source (default: fresh)")
    bag.add_argument("--force", action="store_true", help="overwrite an existing log and spec")


def run_bag(args: argparse.Namespace, console: Console) -> int:
    """Import the bag (and write its spec); what was imported."""
    from beatlog.adapters.rosbag import import_bag

    output: Path = args.output
    with _new_log(output):
        if args.spec is not None and args.spec.exists() and not args.force:
            raise OptionError(f"{args.spec}: already exists (use --force)")
        imported = import_bag(
            args.bag,
            output,
            system=args.system,
            perception=args.perception,
            period_ns=None if args.period_ms is None else round(args.period_ms * 1e6),
            clock_topic=args.clock_topic,
            topics=args.topics,
            spec=args.spec,
            seed=args.seed,
            overwrite=args.force,
        )
    console.print(imported.describe(), markup=False, highlight=False)
    return EXIT_OK
