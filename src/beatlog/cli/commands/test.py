"""``beatlog test``: run DTC specs, or a fleet's logs, as one suite session
(:mod:`beatlog.report.session`); this module reads the options and prints the report."""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from beatlog.baseline.policy import UpdateMode
from beatlog.cli.common import (
    EXIT_NOTHING_SELECTED,
    add_factory,
    add_paths,
    count,
    cycle_number,
    positive_int,
    print_error,
    progress,
    shard,
)
from beatlog.errors import EmptySelectionError, OptionError

if TYPE_CHECKING:
    from rich.console import Console

    from beatlog.suite.runner import SpecOutcome

__all__ = ["add_arguments", "run"]


def add_arguments(test: argparse.ArgumentParser) -> None:
    """The options of ``beatlog test``."""
    add_paths(test, "specs (*.dtc.toml) or folders searched for them")
    where = test.add_mutually_exclusive_group()
    where.add_argument(
        "-j",
        "--jobs",
        type=positive_int,
        help=f"processes replaying at once (default: the number of cores, {os.cpu_count() or 1})",
    )
    where.add_argument(
        "--dask",
        metavar="ADDRESS",
        help="run the DTCs on the Dask cluster whose scheduler is at ADDRESS "
        "(tcp://host:8786), or on one started here with local or local:N worker processes; "
        "each task carries the logs and baselines it reads, and the workers need the "
        'system\'s package installed (pip install "beatlog[dask]"); '
        "a cluster that cannot be reached exits 2",
    )
    test.add_argument(
        "-k",
        dest="pattern",
        metavar="EXPRESSION",
        help="only DTCs matching this expression, as pytest's -k: words matched against "
        "names and tags, with and, or, not and parentheses (e.g. -k 'touch or pat'); "
        "the names are the DTC's, its spec file's and its folders' below the rootdir",
    )
    test.add_argument(
        "--tag",
        action="append",
        dest="tags",
        default=[],
        metavar="TAG",
        help="only DTCs with this tag; given more than once, only DTCs with every tag given",
    )
    test.add_argument(
        "-x",
        "--exitfirst",
        "--fail-fast",
        dest="fail_fast",
        action="store_true",
        help="stop after the first DTC that fails or cannot run; those not started are not run",
    )
    test.add_argument(
        "--lf",
        "--last-failed",
        dest="last_failed",
        action="store_true",
        help="run only the DTCs that failed last time (remembered in .beatlog_cache/), "
        "or all of them when none did",
    )
    test.add_argument("--junit-xml", type=Path, metavar="FILE", help="write a JUnit report")
    test.add_argument(
        "--html", type=Path, metavar="FILE", help="write an HTML report with timeline charts"
    )
    test.add_argument(
        "--update",
        action="store_const",
        const=UpdateMode.NEW,
        default=UpdateMode.NONE,
        help="write the new state changes of failed DTCs to pending files for review",
    )
    test.add_argument(
        "--audit",
        action="store_true",
        help="also replay each DTC twice with different hash seeds, watching for wall-clock "
        "reads and global random calls",
    )
    test.add_argument(
        "--coverage",
        action="store_true",
        help="show which behavior states the DTCs exercise and the changes between them from "
        "one heartbeat to the next, and the states declared or seen by earlier runs "
        "(remembered in .beatlog_cache/) that none reaches",
    )
    test.add_argument(
        "--coverage-json", type=Path, metavar="FILE", help="write the transition coverage as JSON"
    )
    test.add_argument(
        "--behavior",
        metavar="NAME",
        help="run only the DTCs whose recordings change this behavior's state",
    )
    test.add_argument(
        "--shard",
        type=shard,
        metavar="I/N",
        help="run only shard I of N (from 1), split evenly by recorded cycles: "
        "N CI jobs with --shard 1/N ... N/N run every DTC once",
    )
    test.add_argument(
        "--logs",
        metavar="GLOB",
        help="replay every matching log against --system, no spec needed "
        '(a local glob, or a URL with pip install "beatlog[fleet]")',
    )
    add_factory(test, "--system", "the system factory of a --logs run")
    add_factory(
        test,
        "--perception",
        "the perception step of a --logs run: rebuild each robot state from the samples",
    )
    test.add_argument(
        "--variants",
        type=count,
        metavar="N",
        help="also replay variants 1..N of each DTC that declares variants ([variants] in "
        "its spec or [tool.beatlog.variants]), perturbed, judged by its behaviors not "
        "raising and its invariants; a failing variant is written as a spec beside its DTC "
        "(default: each DTC's own count)",
    )
    test.add_argument(
        "--break-at",
        type=cycle_number,
        metavar="CYCLE",
        help="stop in the debugger just before the behaviors update in this cycle "
        "(one DTC only: select it with -k or name its spec; runs in this process)",
    )
    test.add_argument(
        "--break-on-divergence",
        action="store_true",
        help="replay each failing DTC again and stop in the debugger at its first divergence "
        "(runs in this process)",
    )


def run(args: argparse.Namespace, console: Console) -> int:
    """Run the suite with a progress bar, each failure (every DTC with ``--verbose``)
    shown as it comes, then the session's report and its counts; exit 5 when nothing
    is selected, as pytest does."""
    from beatlog.report.session import SuiteSession
    from beatlog.suite.selection import SuiteOptions

    # each of the suite's options from the option of the same name
    given = {field.name: getattr(args, field.name) for field in dataclasses.fields(SuiteOptions)}
    try:
        session = SuiteSession(
            SuiteOptions(**given | {"paths": tuple(args.paths), "tags": tuple(args.tags)})
        )
    except EmptySelectionError as exc:
        print_error(str(exc))
        return EXIT_NOTHING_SELECTED
    if session.selection.note is not None:
        console.print(session.selection.note, markup=False, highlight=False)
    # no bar under a debugger
    bar = progress(
        console,
        "{task.completed}/{task.total} DTCs",
        "{task.fields[rate]}",
        hidden=session.options.breaking,
    )
    started = time.perf_counter()
    cycles = 0

    def on_outcome(outcome: SpecOutcome) -> None:
        nonlocal cycles
        cycles += outcome.result.cycles if outcome.result else 0
        rate = f"{cycles / max(time.perf_counter() - started, 1e-9):,.0f} cycles/s"
        bar.update(task, advance=1, rate=rate)
        _show(outcome, bar.console, verbose=args.verbose)

    with bar:
        task = bar.add_task("replaying", total=len(session.specs), rate="")
        ran = session.run(on_outcome)
    for line in ran.summary(every=args.verbose):
        console.print(line)
    report = session.finish()
    for line in report.baseline_lines():
        console.print(line, highlight=False)
    for line in report.coverage_lines():
        console.print(line)
    for warning in report.warnings:
        print(f"beatlog: warning: {warning}", file=sys.stderr)
    if report.error is not None:
        raise OptionError(report.error)
    console.print(report.closing_line())
    if report.interrupted is not None:
        raise report.interrupted
    return report.exit_code


def _show(outcome: SpecOutcome, console: Console, *, verbose: bool) -> None:
    """A DTC's outcome as it comes: an error on stderr, a failure (any, with
    ``verbose``) in full, and a retry."""
    from beatlog.report.console import render_outcome
    from beatlog.report.counts import plural
    from beatlog.suite.runner import Verdict

    if outcome.verdict is Verdict.ERROR:
        print_error(
            f"{outcome.spec.label} ({outcome.spec.origin}): {outcome.error}",
            outcome.error_traceback if verbose else None,
        )
    elif outcome.verdict is Verdict.FAILED or verbose:
        console.print(render_outcome(outcome))
    if outcome.retries:
        died = f"the worker replaying it died ({plural(outcome.retries, 'time')})"
        console.print(f"retried {outcome.spec.label}: {died}", markup=False, highlight=False)
