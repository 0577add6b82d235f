"""What the subcommands share: a parser whose errors are one line and exit code 2, the
arguments they take, the exit codes, the one-line error, the session logs and outputs
they name, and the progress bar."""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn, TypeVar

from beatlog.errors import BeatlogError, OptionError

if TYPE_CHECKING:
    from rich.console import Console
    from rich.progress import Progress

    from beatlog.suite.parallel import Shard

__all__ = [
    "EXIT_CODES",
    "EXIT_FAILED",
    "EXIT_INTERRUPTED",
    "EXIT_NOTHING_SELECTED",
    "EXIT_OK",
    "EXIT_TERMINATED",
    "EXIT_USAGE",
    "Parser",
    "add_factory",
    "add_invariants",
    "add_log",
    "add_output",
    "add_paths",
    "count",
    "cycle_number",
    "field_pair",
    "positive_float",
    "positive_int",
    "print_error",
    "progress",
    "readable",
    "references",
    "shard",
]

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED, EXIT_TERMINATED = 0, 1, 2, 130, 143
EXIT_NOTHING_SELECTED = 5
"""``beatlog test`` found DTC specs and selected none, as pytest's exit code 5."""
EXIT_CODES = """exit codes:
  0    passed (or done)
  1    a replay diverged, a DTC failed or a recording failed (shrink: it passes)
  2    bad input or usage: one line on stderr naming the file and the problem
  5    beatlog test selected no DTC (-k and --tag match none of the specs found)
  130  interrupted (Ctrl-C, or quitting the debugger at a break)
  143  terminated (SIGTERM), stopped as Ctrl-C stops it"""


def print_error(problem: str, user_traceback: str | None = None) -> None:
    """One line on stderr; with ``--verbose`` the user's traceback before it."""
    if user_traceback:
        sys.stderr.write(user_traceback)
    print(f"beatlog: error: {problem}", file=sys.stderr)


@contextlib.contextmanager
def readable(args: argparse.Namespace) -> Iterator[str | None]:
    """``args.log`` as a file of this machine while the block runs: a log behind a URL
    is copied once (with a progress bar on a terminal), ``args.log`` names the copy,
    which is removed after, and errors raised in the block name it by its URL. The
    block is given the URL; None for a local log. A spec given for a log is refused
    with the command that runs it."""
    from beatlog.baseline.file import SPEC_SUFFIX
    from beatlog.errors import NotABeatlogError
    from beatlog.suite.remote import fetched_log, is_url

    url = str(args.log)
    if url.endswith(SPEC_SUFFIX):
        raise NotABeatlogError(url, "a DTC spec, not a session log (beatlog test runs it)")
    if not is_url(url):
        yield None
        return
    with fetched_log(url, progress=True) as copy:
        args.log = copy
        try:
            yield url
        except BeatlogError as exc:
            exc.args = (str(exc).replace(str(copy), url),)
            raise


def progress(console: Console, *figures: str, hidden: bool = False) -> Progress:
    """A transient progress bar: what runs, the bar, ``figures`` (templates of the
    task's fields) and the time taken; drawn only where it can be redrawn (a terminal:
    no blank line left behind) and not ``hidden``."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        *map(TextColumn, figures),
        TimeElapsedColumn(),
        console=console,
        transient=True,
        disable=not console.is_terminal or hidden,
    )


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
    from beatlog.suite.parallel import Shard

    try:
        return Shard.parse(text)
    except OptionError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _number(
    kind: Callable[[str], Number], what: str, *, zero: bool = False
) -> Callable[[str], Number]:
    """An option's type: ``kind`` above 0, or (``zero``) 0 or more."""

    def parse(text: str) -> Number:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not {what}: {text!r}") from None
        if value < 0 or not (zero or value > 0):
            raise argparse.ArgumentTypeError(
                f"must be {'0 or more' if zero else 'positive'}: {text!r}"
            )
        return value

    return parse


cycle_number = _number(int, "a cycle number", zero=True)
"""A cycle of a log: 0 or more."""
count = _number(int, "a whole number", zero=True)
"""How many of something: a whole number, 0 or more."""
positive_float = _number(float, "a number")
"""A number above 0."""
positive_int = _number(int, "a whole number")
"""A whole number above 0."""


def field_pair(text: str) -> tuple[str, str]:
    """``NAME=VALUE`` of ``--rename-field`` and ``--convert-field``, split."""
    name, sep, value = text.partition("=")
    if not (sep and name and value):
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE: {text!r}")
    return name, value
