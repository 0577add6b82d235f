"""The ``beatlog`` command line, built from the table of subcommands: each has a
``--help`` page that says what it does and ends with the exit codes."""

from __future__ import annotations

import argparse

from beatlog._version import __version__
from beatlog.cli.arguments import Parser
from beatlog.cli.commands import COMMANDS
from beatlog.cli.common import EXIT_CODES

__all__ = ["build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``beatlog`` and of every subcommand in
    :data:`~beatlog.cli.commands.COMMANDS`."""
    parser = Parser(
        prog="beatlog",
        description="Record robot sessions and replay them as deterministic test cases.",
        epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"beatlog {__version__}")
    parser.set_defaults(beatlog_parser=parser)  # for ``beatlog help``, which prints its pages
    commands = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for name, command in COMMANDS.items():
        common = Parser(add_help=False)
        common.add_argument("-v", "--verbose", action="store_true", help=command.verbose)
        subcommand = commands.add_parser(
            name,
            parents=[common],
            help=command.help,
            description=command.help[0].upper() + command.help[1:] + ".",
            epilog=EXIT_CODES,
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        command.add_arguments(subcommand)
    return parser
