"""The subcommands of ``beatlog``, a module for each job (those of one log, of
baselines, of new logs share one), listed once in :data:`COMMANDS`: the
parser is built from the table (:func:`beatlog.cli.main.build_parser`) and the entry
point runs from it. A module declares its command's arguments (``add_arguments``) and
carries it out (``run``), importing what it uses when it runs, so that ``beatlog
--help`` loads neither the engines nor rich."""

from __future__ import annotations

import argparse
import functools
from collections.abc import Callable
from typing import TYPE_CHECKING, NamedTuple

from beatlog.cli.commands import (
    baselines,
    demo,
    logs,
    record,
    replay,
    shrink,
    test,
)
from beatlog.cli.commands import help as helping
from beatlog.cli.common import add_log, add_paths

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["COMMANDS", "Command"]


class Command(NamedTuple):
    """One subcommand: what it does, its arguments, and what carries it out."""

    help: str
    """What it does, in a line: its ``--help`` page says it too."""
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace, Console], int]
    """Carries the command out; its exit code."""
    runs_user_code: bool = True
    """Whether it imports the user's code (``module:factory``)."""
    verbose: str | None = "also print the traceback of user code that failed to load"
    """What ``--verbose`` does for it; None where it would do nothing (no ``-v``)."""


COMMANDS: dict[str, Command] = {
    "record": Command(
        "run a robot in real time and record a session", record.add_arguments, record.run
    ),
    "replay": Command("replay a session log and give a verdict", replay.add_arguments, replay.run),
    "test": Command(
        "run DTC specs (*.dtc.toml) in parallel",
        test.add_arguments,
        test.run,
        verbose="list every DTC in the summary, and print the traceback of user code "
        "that failed to load",
    ),
    "shrink": Command(
        "find the shortest window of cycles (and fewest perturbations) that still fails a "
        "DTC the same way, and write it as a spec beside it",
        shrink.add_arguments,
        shrink.run,
    ),
    "review": Command(
        "show each pending baseline change with what it loses, and ask whether to accept, "
        "reject or skip it (and each loss); accepting writes the approved baseline",
        functools.partial(add_paths, what="specs or folders with pending baselines"),
        baselines.run_review,
    ),
    "approve": Command(
        "accept every pending baseline of DTC specs without asking, naming each loss it "
        "accepts (nothing pending is no error)",
        baselines.add_approve_arguments,
        baselines.run_approve,
    ),
    "upgrade-baselines": Command(
        "rewrite baselines of older formats in the current one (recordings are untouched)",
        functools.partial(
            add_paths, what="baselines, specs, or folders with approved and pending baselines"
        ),
        baselines.run_upgrade,
        runs_user_code=False,
        verbose=None,
    ),
    "show": Command(
        "describe a session log",
        functools.partial(add_log, doing="describe"),
        logs.run_show,
        runs_user_code=False,
        verbose=None,
    ),
    "plot": Command(
        "draw a timeline chart of a session log (PNG, SVG or PDF)",
        logs.add_plot_arguments,
        logs.run_plot,
    ),
    "export": Command(
        "write a session log as MCAP for Foxglove and Lichtblick, or a table",
        logs.add_export_arguments,
        logs.run_export,
    ),
    "import-bag": Command(
        "turn a ROS bag into a session log with samples, replayable at sensor level",
        record.add_bag_arguments,
        record.run_bag,
    ),
    "help": Command(
        "show the help of beatlog or of one of its commands, or what a word it prints means",
        lambda parser: helping.add_arguments(parser, topics=COMMANDS),
        helping.run,
        runs_user_code=False,
        verbose=None,
    ),
    "demo": Command(
        "record and replay the robot dog, then its suite",
        demo.add_arguments,
        demo.run,
        runs_user_code=False,
    ),
}
"""Every subcommand by name, in the order ``beatlog --help`` lists them."""
