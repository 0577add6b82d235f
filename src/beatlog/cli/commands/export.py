"""``beatlog export``: write a session log as MCAP for viewers, or as a table."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from beatlog.cli.arguments import add_factory, add_log, add_output
from beatlog.cli.common import EXIT_FAILED, EXIT_OK, readable

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["EXPORT_FORMATS", "add_arguments", "run"]

EXPORT_FORMATS = ("mcap", "parquet", "csv")
"""``beatlog export --format`` (:class:`beatlog.adapters.export.ExportFormat`), here so
that parsing the command line imports nothing heavy."""


def add_arguments(export: argparse.ArgumentParser) -> None:
    """The options of ``beatlog export``."""
    add_log(export, "export")
    add_output(export, "the file to write; its suffix picks the format: .mcap, .parquet or .csv")
    export.add_argument(
        "--format",
        choices=EXPORT_FORMATS,
        help="mcap (JSON messages, for viewers), parquet or csv (a row per cycle); "
        "default: the output's suffix, which must not name another format",
    )
    add_factory(
        export,
        "--system",
        "also replay against this system and add its first divergence (MCAP only)",
    )


def run(args: argparse.Namespace, console: Console) -> int:
    """Export the log; 1 when the system given diverges from it."""
    import dataclasses

    from beatlog.adapters.export import export, export_format

    chosen = export_format(args.output, args.format)  # refused before anything runs
    with readable(args) as url:
        result = export(args.log, args.output, format=chosen, system=args.system)
    result = dataclasses.replace(result, url=url)
    console.print(result.describe(), markup=False, highlight=False)
    return EXIT_OK if result.divergence is None else EXIT_FAILED
