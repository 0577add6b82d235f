"""``beatlog review``: show each pending baseline change and ask whether to accept it."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from beatlog.cli.arguments import add_paths
from beatlog.cli.common import EXIT_OK

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["add_arguments", "run"]


def add_arguments(review: argparse.ArgumentParser) -> None:
    """The arguments of ``beatlog review``."""
    add_paths(review, "specs or folders with pending baselines")


def run(args: argparse.Namespace, console: Console) -> int:
    """Review what is pending (see :func:`beatlog.cli.baselines.review`)."""
    from beatlog.cli.baselines import review

    review(args.paths, console)
    return EXIT_OK
