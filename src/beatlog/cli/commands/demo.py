"""``beatlog demo``: record and replay the robot dog, then its suite."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from beatlog.cli.common import positive_float
from beatlog.errors import BeatlogError

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["add_arguments", "run"]


def add_arguments(demo: argparse.ArgumentParser) -> None:
    """The options of ``beatlog demo``."""
    demo.add_argument(
        "--duration",
        type=positive_float,
        default=20.0,
        help="seconds to record (default: %(default)s)",
    )
    demo.add_argument(
        "--out",
        type=Path,
        default=Path("beatlog-demo"),
        help="the folder to keep the demo log in (default: %(default)s)",
    )


def run(args: argparse.Namespace, console: Console) -> int:
    """Run the demo a package registered under the ``beatlog.demo`` entry point group."""
    from importlib.metadata import entry_points

    demos = entry_points(group="beatlog.demo")
    if not demos:
        raise BeatlogError(
            "beatlog demo needs the example robots: pip install beatlog-examples "
            "(in a clone of beatlog: pip install -e examples)"
        )
    run_demo = next(iter(demos)).load()
    return int(run_demo(console, duration_s=args.duration, out=args.out))
