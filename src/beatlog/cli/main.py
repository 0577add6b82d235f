"""The ``beatlog`` command: a thin shell over the library.

It builds the parser from :data:`beatlog.cli.commands.COMMANDS` (each subcommand's
``--help`` page ends with the exit codes, :data:`~beatlog.cli.common.EXIT_CODES`), runs
the subcommand, and turns what stops it into an exit code: a :class:`BeatlogError` into
one line on stderr and 2, Ctrl-C into 130, SIGTERM into 143.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import sys
import threading
from collections.abc import Iterator, Sequence
from types import FrameType

from beatlog._version import __version__
from beatlog.cli.commands import COMMANDS
from beatlog.cli.common import (
    EXIT_CODES,
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    EXIT_USAGE,
    Parser,
    print_error,
)
from beatlog.errors import BeatlogError
from beatlog.project.interpreters import quiet_abandoned_reads

__all__ = ["EXIT_CODES", "build_parser", "main"]


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit code (the console script exits with it)."""
    verbose = False
    with _signals_as_interrupts() as terminated:
        try:
            args = build_parser().parse_args(argv)
            verbose = args.verbose
            from rich.console import Console

            console = Console(soft_wrap=True)  # long commands stay one line, for copy and paste
            command = COMMANDS[args.command]
            if command.runs_user_code and not {"", os.getcwd()} & set(sys.path):
                # MODULE:FACTORY names a module of the working directory, as with python -m
                # (the console script's sys.path starts with its own bin directory)
                sys.path.insert(0, os.getcwd())
            return command.run(args, console)
        except BeatlogError as exc:
            print_error(str(exc), exc.user_traceback if verbose else None)
            return EXIT_USAGE
        except KeyboardInterrupt as stop:
            if terminated.is_set():
                print("beatlog: terminated", file=sys.stderr)
                return EXIT_TERMINATED
            print(f"beatlog: {_interruption(stop)}", file=sys.stderr)
            return EXIT_INTERRUPTED


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
    parser.set_defaults(beatlog_parser=parser, verbose=False)  # beatlog help prints its pages
    commands = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for name, command in COMMANDS.items():
        subcommand = commands.add_parser(
            name,
            help=command.help,
            description=command.help[0].upper() + command.help[1:] + ".",
            epilog=EXIT_CODES,
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        if command.verbose is not None:
            subcommand.add_argument("-v", "--verbose", action="store_true", help=command.verbose)
        command.add_arguments(subcommand)
    return parser


def _interruption(stop: KeyboardInterrupt) -> str:
    """What stopped the command: Ctrl-C, or the debugger quit at a break (which says so).
    Nothing is imported on the way out: a break imported the debugger where there was one."""
    debugger = sys.modules.get("beatlog.replay.debugger")
    if debugger is not None and isinstance(stop, debugger.DebuggerQuit):
        return str(stop)
    return "interrupted"


@contextlib.contextmanager
def _signals_as_interrupts() -> Iterator[threading.Event]:
    """While the block runs, SIGTERM stops the command as Ctrl-C does (a
    ``KeyboardInterrupt``, so what it holds is cleaned up: a log closed, downloaded
    copies removed); the event given is set once it came. From either signal on, what
    the interruption abandons (an async download's read, scheduled and never started)
    is not the user's: no warning of a coroutine never awaited, also while the block
    unwinds. Only the main thread can handle signals: elsewhere they are left as they
    are, and so is a Ctrl-C this process was started deaf to."""
    terminated = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield terminated
        return

    def interrupt(signum: int, frame: FrameType | None) -> None:
        quiet_abandoned_reads()
        if signum == signal.SIGTERM:
            terminated.set()
        raise KeyboardInterrupt

    handled = [signal.SIGTERM]
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        handled.append(signal.SIGINT)
    previous = {signum: signal.signal(signum, interrupt) for signum in handled}
    try:
        yield terminated
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, signal.SIG_DFL if handler is None else handler)


if __name__ == "__main__":
    sys.exit(main())
