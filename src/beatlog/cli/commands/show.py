"""``beatlog show``: describe a session log."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from beatlog.cli.common import EXIT_OK, readable

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["add_arguments", "run"]


def add_arguments(show: argparse.ArgumentParser) -> None:
    """The arguments of ``beatlog show``."""
    show.add_argument("log", help="the session log (.beatlog) to describe: a path or a URL")


def run(args: argparse.Namespace, console: Console) -> int:
    """The log's header and figures, a log behind a URL named by its URL."""
    import dataclasses

    from beatlog.analysis.summary import summarize
    from beatlog.report.console import render_summary

    given = args.log
    with readable(args) as named:
        summary = summarize(args.log)
    if named is not None:
        summary = dataclasses.replace(summary, url=given)
    console.print(render_summary(summary))
    return EXIT_OK
