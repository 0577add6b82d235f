"""Reading the command line: an argparse parser whose errors are one line and exit code
2, and the types of the arguments the subcommands take."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn, TypeVar

from beatlog.errors import OptionError

if TYPE_CHECKING:
    from beatlog.suite.sharding import Shard

__all__ = [
    "Parser",
    "add_factory",
    "add_log",
    "add_output",
    "add_paths",
    "count",
    "cycle_number",
    "positive_float",
    "positive_int",
    "shard",
]

Number = TypeVar("Number", int, float)


class Parser(argparse.ArgumentParser):
    """argparse that reports a usage error in one line and exit code 2."""

    def error(self, message: str) -> NoReturn:
        raise OptionError(f"{message} (see '{self.prog} --help')")


def add_log(parser: argparse.ArgumentParser, doing: str) -> None:
    """The session log a command reads (``doing`` says what it does with it)."""
    parser.add_argument("log", help=f"the session log (.beatlog) to {doing}: a path or a URL")


def add_paths(parser: argparse.ArgumentParser, what: str) -> None:
    """The specs or folders a command works on, the current folder by default."""
    parser.add_argument(
        "paths",
        nargs="*",
        type=Path,
        default=[Path()],
        help=f"{what} (default: the current folder)",
    )


def add_output(parser: argparse.ArgumentParser, what: str) -> None:
    """The file a command writes, ``-o FILE``; ``what`` says what it is."""
    parser.add_argument("-o", "--output", required=True, type=Path, metavar="FILE", help=what)


def add_factory(
    parser: argparse.ArgumentParser, option: str, what: str, *, required: bool = False
) -> None:
    """An option naming the user's code as ``MODULE:FACTORY`` (a system, a perception step)."""
    parser.add_argument(option, required=required, metavar="MODULE:FACTORY", help=what)


def add_invariants(parser: argparse.ArgumentParser, doing: str) -> None:
    """``--invariants``: the invariants to check in each cycle, as ``MODULE:ATTRIBUTE``
    references, comma-separated or the option repeated."""
    parser.add_argument(
        "--invariants",
        action="extend",
        type=references,
        default=[],
        metavar="MODULE:ATTRIBUTE[,...]",
        help=f"invariants to check in each cycle {doing} (functions, or classes "
        "instantiated afresh); comma-separated, or repeat the option",
    )


def references(text: str) -> list[str]:
    """Comma-separated ``module:attribute`` references."""
    found = [reference.strip() for reference in text.split(",")]
    for reference in found:
        module, _, attribute = reference.partition(":")
        if not (module and attribute):
            raise argparse.ArgumentTypeError(f"expected MODULE:ATTRIBUTE, got {reference!r}")
    return found


def shard(text: str) -> Shard:
    """``I/N``: one shard of a suite."""
    from beatlog.suite.sharding import Shard

    try:
        return Shard.parse(text)
    except OptionError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def cycle_number(text: str) -> int:
    """A cycle of a log: 0 or more."""
    return _number(text, int, "a cycle number", zero=True)


def count(text: str) -> int:
    """How many of something: a whole number, 0 or more."""
    return _number(text, int, "a whole number", zero=True)


def positive_float(text: str) -> float:
    """A number above 0."""
    return _number(text, float, "a number")


def positive_int(text: str) -> int:
    """A whole number above 0."""
    return _number(text, int, "a whole number")


def _number(text: str, kind: Callable[[str], Number], what: str, *, zero: bool = False) -> Number:
    """``text`` as a ``kind`` above 0, or (``zero``) 0 or more."""
    try:
        value = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not {what}: {text!r}") from None
    if value < 0 or not (zero or value > 0):
        raise argparse.ArgumentTypeError(f"must be {'0 or more' if zero else 'positive'}: {text!r}")
    return value


def field_pair(text: str) -> tuple[str, str]:
    """``NAME=VALUE`` of ``--rename-field`` and ``--convert-field``, split."""
    name, sep, value = text.partition("=")
    if not (sep and name and value):
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE: {text!r}")
    return name, value
