"""``beatlog help [COMMAND]``: the help page ``--help`` prints."""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from typing import TYPE_CHECKING

from beatlog.cli.common import EXIT_OK

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["add_arguments", "run"]


def add_arguments(helping: argparse.ArgumentParser, *, topics: Iterable[str]) -> None:
    """The argument of ``beatlog help``: any of the commands ``topics``."""
    helping.add_argument(
        "topic", nargs="?", choices=sorted(topics), metavar="COMMAND", help="the command"
    )


def run(args: argparse.Namespace, console: Console) -> int:
    """Print the help page of beatlog, or of the command named, with the parser that
    parsed ``args`` (:func:`beatlog.cli.parser.build_parser` hands it over)."""
    args.beatlog_parser.parse_args([*([args.topic] if args.topic else []), "--help"])
    return EXIT_OK
