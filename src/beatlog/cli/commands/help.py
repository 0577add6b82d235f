"""``beatlog help [COMMAND | TERM]``: the help page ``--help`` prints, or what a word the
terminal printed means (from the glossary, :mod:`beatlog.report.glossary`)."""

from __future__ import annotations

import argparse
from collections.abc import Collection
from typing import TYPE_CHECKING

from beatlog.cli.common import EXIT_OK
from beatlog.errors import OptionError

if TYPE_CHECKING:
    from rich.console import Console

    from beatlog.report.glossary import Entry

__all__ = ["add_arguments", "run"]


def add_arguments(helping: argparse.ArgumentParser, *, topics: Collection[str]) -> None:
    """The arguments of ``beatlog help``: a command of ``topics`` or a glossary term."""
    helping.add_argument(
        "topic",
        nargs="*",
        metavar="COMMAND|TERM",
        help=f"a command ({', '.join(topics)}), or a word beatlog prints, such as open-loop",
    )
    helping.add_argument(
        "--glossary", action="store_true", help="print every word beatlog prints, with its meaning"
    )
    helping.set_defaults(beatlog_commands=tuple(topics))


def run(args: argparse.Namespace, console: Console) -> int:
    """Print the help page of beatlog or of the command named, with the parser that
    parsed ``args`` (:func:`beatlog.cli.main.build_parser` hands it over), or the
    glossary's entry for the term named, or the whole glossary."""
    from beatlog.report import glossary

    topic = " ".join(args.topic)
    if args.glossary:
        for each in glossary.entries():
            _print_entry(each, console)
        return EXIT_OK
    if not topic or topic in args.beatlog_commands:
        args.beatlog_parser.parse_args([*([topic] if topic else []), "--help"])  # exits
        return EXIT_OK
    entry = glossary.lookup(topic)
    if entry is None:
        near = glossary.near(topic)
        hint = f"; did you mean {' or '.join(map(repr, near))}?" if near else ""
        raise OptionError(
            f"{topic!r} is neither a command nor a word of the glossary{hint} "
            "(beatlog help --glossary lists them)"
        )
    _print_entry(entry, console)
    return EXIT_OK


def _print_entry(entry: Entry, console: Console) -> None:
    """The term, what it means, its other spellings and where the documentation says more."""
    from rich.padding import Padding
    from rich.text import Text

    lines = [Text(entry.meaning)]
    if entry.aliases:
        lines.append(Text(f"also printed as: {', '.join(entry.aliases)}", style="dim"))
    if entry.see:
        lines.append(Text(f"more: docs/{entry.see}", style="dim"))
    console.print(Text(entry.term, style="bold"))
    for line in lines:
        console.print(Padding(line, (0, 0, 0, 2), expand=False), soft_wrap=False)
