"""What the subcommands share: the exit codes, the one-line error, and the session logs
and outputs they name."""

from __future__ import annotations

import argparse
import contextlib
import functools
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

from beatlog.errors import BeatlogError, OptionError

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
def readable(args: argparse.Namespace) -> Iterator[Callable[[str], str] | None]:
    """``args.log`` as a file of this machine while the block runs: a log behind a URL
    is copied once (:func:`beatlog.suite.remote.fetched_log`, with a progress bar on a
    terminal) and ``args.log`` names the copy, which is removed after. The block is
    given a function that names the copy by its URL in a text, and errors raised in it
    are named so too; None for a local log."""
    from beatlog.suite.remote import fetched_log, is_url, named_as_given

    url = str(args.log)
    if not is_url(url):
        yield None
        return
    with fetched_log(url, progress=True) as copy:
        args.log = copy
        try:
            yield functools.partial(named_as_given, copy=copy, url=url)
        except BeatlogError as exc:
            exc.args = (named_as_given(str(exc), copy, url),)
            raise
