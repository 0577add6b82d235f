"""What the subcommands share: the exit codes, the one-line error, the session logs
and outputs they name, and the progress bar."""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from beatlog.errors import BeatlogError, OptionError

if TYPE_CHECKING:
    from rich.console import Console
    from rich.progress import Progress

__all__ = [
    "EXIT_CODES",
    "EXIT_FAILED",
    "EXIT_INTERRUPTED",
    "EXIT_NOTHING_SELECTED",
    "EXIT_OK",
    "EXIT_TERMINATED",
    "EXIT_USAGE",
    "check_output",
    "print_error",
    "progress",
    "readable",
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


def check_output(output: Path) -> None:
    """Refuse a log to write before any work: its folder is missing, or it is a folder."""
    if not output.parent.is_dir():
        raise OptionError(f"{output}: directory {output.parent} does not exist")
    if output.is_dir():
        raise OptionError(f"{output}: is a directory")


@contextlib.contextmanager
def readable(args: argparse.Namespace) -> Iterator[str | None]:
    """``args.log`` as a file of this machine while the block runs: a log behind a URL
    is copied once (with a progress bar on a terminal), ``args.log`` names the copy,
    which is removed after, and errors raised in the block name it by its URL. The
    block is given the URL; None for a local log."""
    from beatlog.suite.remote import fetched_log, is_url, named_as_given

    url = str(args.log)
    if not is_url(url):
        yield None
        return
    with fetched_log(url, progress=True) as copy:
        args.log = copy
        try:
            yield url
        except BeatlogError as exc:
            exc.args = (named_as_given(str(exc), copy, url),)
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
