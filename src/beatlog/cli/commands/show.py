"""``beatlog show``: describe a session log."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from beatlog.cli.arguments import add_log
from beatlog.cli.common import EXIT_OK, readable

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["add_arguments", "run"]


def add_arguments(show: argparse.ArgumentParser) -> None:
    """The arguments of ``beatlog show``."""
    add_log(show, "describe")


def run(args: argparse.Namespace, console: Console) -> int:
    """The log's header and figures, a log behind a URL named by its URL, and the
    approved baselines of the specs beside it that name it."""
    import dataclasses

    from beatlog.analysis.summary import summarize
    from beatlog.report.baselines import render_approved
    from beatlog.report.console import render_summary
    from beatlog.suite.approved import approved_baselines

    with readable(args) as url:
        summary = dataclasses.replace(summarize(args.log), url=url)
        approved = [] if url is not None else approved_baselines(args.log)
    console.print(render_summary(summary))
    for baseline in approved:
        console.print(render_approved(baseline))
    return EXIT_OK
