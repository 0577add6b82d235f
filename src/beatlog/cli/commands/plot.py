"""``beatlog plot``: draw a timeline chart of a session log."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from beatlog.cli.arguments import add_factory, add_log, add_output
from beatlog.cli.common import EXIT_OK, readable
from beatlog.errors import OptionError

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["add_arguments", "run"]


def add_arguments(plot: argparse.ArgumentParser) -> None:
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


def run(args: argparse.Namespace, console: Console) -> int:
    """Draw the chart, with the first divergence where a system is given."""
    try:
        import matplotlib  # noqa: F401
    except ModuleNotFoundError:
        raise OptionError('plot needs matplotlib (pip install "beatlog[plot]")') from None
    from beatlog.analysis.timeline import build_timeline
    from beatlog.replaying.judge import replay
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
