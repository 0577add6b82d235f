"""``beatlog import-bag``: turn a ROS bag into a session log, replayable at sensor level."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from beatlog.cli.arguments import add_factory, positive_float
from beatlog.cli.common import EXIT_OK, check_output
from beatlog.errors import LogExistsError, OptionError

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["add_arguments", "run"]


def add_arguments(bag: argparse.ArgumentParser) -> None:
    """The options of ``beatlog import-bag``."""
    bag.add_argument("bag", type=Path, help="the rosbag2 folder (mcap or sqlite3), or its file")
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


def run(args: argparse.Namespace, console: Console) -> int:
    """Import the bag (and write its spec); what was imported."""
    from beatlog.adapters.rosbag import import_bag

    output: Path = args.output
    check_output(output)
    if args.spec is not None and args.spec.exists() and not args.force:
        raise OptionError(f"{args.spec}: already exists (use --force)")
    try:
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
    except LogExistsError:
        raise OptionError(f"{output}: already exists (use --force)") from None
    console.print(imported.describe(), markup=False, highlight=False)
    return EXIT_OK
