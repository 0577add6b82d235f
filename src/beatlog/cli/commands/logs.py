"""The commands that read one session log, a path or a URL: ``beatlog show`` describes
it, ``beatlog plot`` draws it, ``beatlog export`` writes it in another format."""

from __future__ import annotations

import argparse
import dataclasses
from typing import TYPE_CHECKING

from beatlog.cli.common import EXIT_FAILED, EXIT_OK, add_factory, add_log, add_output, readable
from beatlog.errors import OptionError

if TYPE_CHECKING:
    from rich.console import Console

__all__ = [
    "EXPORT_FORMATS",
    "add_export_arguments",
    "add_plot_arguments",
    "run_export",
    "run_plot",
    "run_show",
]

EXPORT_FORMATS = ("mcap", "parquet", "csv")
"""``beatlog export --format`` (:class:`beatlog.adapters.export.ExportFormat`), here so
that parsing the command line imports nothing heavy."""


def run_show(args: argparse.Namespace, console: Console) -> int:
    """The log's header and figures, a log behind a URL named by its URL, and the
    approved baselines of the specs beside it that name it."""
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


def add_plot_arguments(plot: argparse.ArgumentParser) -> None:
    """The options of ``beatlog plot``."""
    add_log(plot, "draw")
    add_output(plot, "the chart to write; its suffix picks the format: .png, .svg or .pdf")
    add_factory(
        plot,
        "--system",
        "also replay against this system and draw what it did (default: the recording only)",
    )
    plot.add_argument(
        "--field",
        action="append",
        dest="fields",
        metavar="NAME",
        help="robot-state field to draw (repeatable; default: the first few numeric ones)",
    )


def run_plot(args: argparse.Namespace, console: Console) -> int:
    """Draw the chart, with the first divergence where a system is given."""
    try:
        import matplotlib  # noqa: F401
    except ModuleNotFoundError:
        raise OptionError('plot needs matplotlib (pip install "beatlog[plot]")') from None
    from beatlog.analysis.timeline import build_timeline
    from beatlog.replay.judge import replay
    from beatlog.report.chart import chart_format, write_chart

    chart_format(args.output)  # an unknown suffix is refused before anything runs
    with readable(args) as url:
        divergence = (
            None
            if args.system is None
            else replay(args.log, args.system, allow_empty=True).divergence
        )
        timeline = build_timeline(args.log, args.system, fields=args.fields, divergence=divergence)
    try:
        write_chart(timeline, args.output)
    except OSError as exc:
        raise OptionError(f"{args.output}: cannot write: {exc.strerror}") from None
    mark = timeline.divergence
    console.print(
        f"drew {timeline.cycles} cycles of {url or args.log} to {args.output}"
        + ("" if mark is None else f"; first divergence at cycle {mark.cycle} ({mark.kind})"),
        markup=False,
        highlight=False,
    )
    return EXIT_OK


def add_export_arguments(export: argparse.ArgumentParser) -> None:
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


def run_export(args: argparse.Namespace, console: Console) -> int:
    """Export the log; 1 when the system given diverges from it."""
    from beatlog.adapters.export import export, export_format

    chosen = export_format(args.output, args.format)  # refused before anything runs
    with readable(args) as url:
        result = export(args.log, args.output, format=chosen, system=args.system)
    result = dataclasses.replace(result, url=url)
    console.print(result.describe(), markup=False, highlight=False)
    return EXIT_OK if result.divergence is None else EXIT_FAILED
