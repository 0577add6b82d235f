"""``beatlog approve``: accept the pending baselines of DTC specs."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from beatlog.cli.common import EXIT_OK

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["add_arguments", "run"]


def add_arguments(approve: argparse.ArgumentParser) -> None:
    """The arguments of ``beatlog approve``."""
    approve.add_argument(
        "paths", nargs="+", type=Path, help="specs or folders whose pending baselines to accept"
    )


def run(args: argparse.Namespace, console: Console) -> int:
    """Accept everything pending under the paths, naming each."""
    from beatlog.cli.baselines import approve_command

    approve_command(args.paths, console)
    return EXIT_OK
