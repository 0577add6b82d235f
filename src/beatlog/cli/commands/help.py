"""``beatlog help [COMMAND]``: the help page ``--help`` prints."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from beatlog.cli.common import EXIT_OK

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["add_arguments", "run"]


def add_arguments(helping: argparse.ArgumentParser) -> None:
    """The argument of ``beatlog help``: any command there is."""
    from beatlog.cli.commands import COMMANDS

    helping.add_argument(
        "topic", nargs="?", choices=sorted(COMMANDS), metavar="COMMAND", help="the command"
    )


def run(args: argparse.Namespace, console: Console) -> int:
    """Print the help page of beatlog, or of the command named."""
    from beatlog.cli.parser import build_parser

    build_parser().parse_args([*([args.topic] if args.topic else []), "--help"])
    return EXIT_OK
