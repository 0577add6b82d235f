"""The ``beatlog`` command: a thin shell over the library.

Each subcommand imports what it uses when it runs, so that ``beatlog --help`` loads
neither the engines nor rich.

Exit codes: 0 pass, 1 a replay diverged or a recording failed, 2 usage error or bad
input (one line on stderr naming the file and the problem, never a traceback; with
``--verbose`` the traceback of the user's code that failed comes first), 130
interrupted (Ctrl-C, or quitting the debugger at a break: what was complete is printed,
no report is half written), 143
terminated (SIGTERM: stopped as Ctrl-C stops it, temporary copies of logs behind URLs
removed).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import os
import signal
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from contextlib import AbstractContextManager
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, NoReturn, TypeVar

from beatlog._version import __version__
from beatlog.errors import BeatlogError, LogExistsError
from beatlog.suite.policy import UpdateMode

if TYPE_CHECKING:
    from rich.console import Console, RenderableType
    from rich.progress import Progress

    from beatlog.suite.cluster import DaskExecutor
    from beatlog.suite.runner import SpecOutcome
    from beatlog.suite.sharding import Shard
    from beatlog.suite.spec import DtcSpec

__all__ = ["main"]

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED, EXIT_TERMINATED = 0, 1, 2, 130, 143
EXPORT_FORMATS = ("mcap", "parquet", "csv")
"""``beatlog export --format`` (:class:`beatlog.adapters.export.ExportFormat`), here so
that parsing the command line imports nothing heavy."""
DEMO_ENTRY_POINTS = "beatlog.demo"
"""The entry point group of the package whose demo `beatlog demo` runs."""
Number = TypeVar("Number", int, float)
_NAMED_IN_NOTES = 5
"""DTCs named in a note of ``beatlog test`` before the rest are counted."""
EXIT_CODES = """exit codes:
  0    passed (or done)
  1    a replay diverged, a DTC failed or a recording failed
  2    bad input or usage: one line on stderr naming the file and the problem
  130  interrupted (Ctrl-C, or quitting the debugger at a break)
  143  terminated (SIGTERM), stopped as Ctrl-C stops it"""


class _UsageError(BeatlogError):
    """A bad option or argument."""


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error in one line and exit code 2."""

    def error(self, message: str) -> NoReturn:
        raise _UsageError(f"{message} (see '{self.prog} --help')")


def _parser() -> argparse.ArgumentParser:  # noqa: PLR0915 - one table of subcommands
    parser = _Parser(
        prog="beatlog",
        description="Record robot sessions and replay them as deterministic test cases.",
        epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"beatlog {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def add(
        name: str,
        *,
        help: str,
        verbose: str = "also print the traceback of user code that failed to load",
    ) -> argparse.ArgumentParser:
        """A subcommand whose --help page has a description and ends with the exit codes."""
        common = _Parser(add_help=False)
        common.add_argument("-v", "--verbose", action="store_true", help=verbose)
        return commands.add_parser(
            name,
            parents=[common],
            help=help,
            description=help[0].upper() + help[1:] + ".",
            epilog=EXIT_CODES,
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )

    record = add("record", help="run a robot in real time and record a session")
    record.add_argument("--robot", required=True, metavar="MODULE:FACTORY", help="robot factory")
    record.add_argument("-o", "--output", required=True, type=Path, help="the .beatlog to write")
    record.add_argument(
        "--duration", type=_positive_float, required=True, help="robot time to record (s)"
    )
    record.add_argument(
        "--period-ms",
        type=_positive_float,
        default=30.0,
        help="heartbeat period in ms (default: %(default)s)",
    )
    record.add_argument("--seed", type=int, help="seed of the random source (default: fresh)")
    record.add_argument(
        "--robot-id", default="robot", help="name of the robot in the header (default: %(default)s)"
    )
    record.add_argument(
        "--system-ref",
        default="",
        metavar="MODULE:FACTORY",
        help="the system factory replay uses when given none, written into the header "
        "(checked before recording starts)",
    )
    record.add_argument("--log-samples", action="store_true", help="also log raw sensor samples")
    record.add_argument(
        "--flush-interval",
        type=_positive_float,
        default=1.0,
        help="seconds of robot time between flushes to disk (default: %(default)s)",
    )
    record.add_argument("--fsync", action="store_true", help="fsync at every flush")
    record.add_argument("--force", action="store_true", help="overwrite an existing log")

    play = add("replay", help="replay a session log and give a verdict")
    play.add_argument("log", help="the session log (.beatlog) to replay: a path or a URL")
    play.add_argument(
        "--system",
        metavar="MODULE:FACTORY",
        help="system factory (default: the one the log records, from record --system-ref, "
        "where the project lists it under [tool.beatlog] systems in pyproject.toml)",
    )
    play.add_argument(
        "--perception",
        metavar="MODULE:FACTORY",
        help="rebuild each robot state from the logged samples with this perception step",
    )
    play.add_argument("--keep-going", action="store_true", help="count every diverging cycle")
    play.add_argument(
        "--recording",
        action="store_true",
        help="judge against the recording, not the approved baseline of the spec beside the "
        "log that names it (which replay, like test, uses by default)",
    )
    play.add_argument(
        "--break-at",
        type=_cycle_number,
        metavar="CYCLE",
        help="stop in the debugger just before the behaviors update in this cycle",
    )
    play.add_argument(
        "--break-on-divergence",
        action="store_true",
        help="replay again and stop in the debugger at the first divergence",
    )
    play.add_argument("--allow-truncated", action="store_true", help="pass a log that was cut off")
    play.add_argument(
        "--allow-empty",
        action="store_true",
        help="pass a replay that checks nothing (no cycle, or nothing happening in any)",
    )
    play.add_argument(
        "--rename-field",
        action="append",
        type=_field_pair,
        default=[],
        metavar="OLD=NEW",
        help="a robot-state field renamed since the recording (a dotted path inside a "
        "struct); repeat for more",
    )
    play.add_argument(
        "--convert-field",
        action="append",
        type=_field_pair,
        default=[],
        metavar="FIELD=MODULE:FUNCTION",
        help="a robot-state field retyped since the recording, and the function that "
        "converts its recorded value; repeat for more",
    )
    play.add_argument("--json", action="store_true", help="print the result as JSON")

    _add_test(
        add(
            "test",
            help="run DTC specs (*.dtc.toml) in parallel",
            verbose="list every DTC in the summary, and print the traceback of user code "
            "that failed to load",
        )
    )

    check = add(
        "review",
        help="show each pending baseline change and ask at the terminal whether to accept, "
        "reject or skip it",
    )
    check.add_argument(
        "paths",
        nargs="*",
        type=Path,
        default=[Path()],
        help="specs or folders with pending baselines (default: the current folder)",
    )
    accept = add("approve", help="accept the pending baselines of DTC specs")
    accept.add_argument(
        "paths", nargs="+", type=Path, help="specs or folders whose pending baselines to accept"
    )

    show = add("show", help="describe a session log")
    show.add_argument("log", help="the session log (.beatlog) to describe: a path or a URL")

    plot = add("plot", help="draw a timeline chart of a session log (PNG, SVG or PDF)")
    plot.add_argument("log", help="the session log (.beatlog) to draw: a path or a URL")
    plot.add_argument(
        "-o",
        "--output",
        required=True,
        type=Path,
        metavar="FILE",
        help="the chart to write; its suffix picks the format: .png, .svg or .pdf",
    )
    plot.add_argument(
        "--system",
        metavar="MODULE:FACTORY",
        help="also replay against this system and draw what it did (default: the recording only)",
    )
    plot.add_argument(
        "--field",
        action="append",
        dest="fields",
        metavar="NAME",
        help="robot-state field to draw (repeatable; default: the first few numeric ones)",
    )

    _add_export(add)
    _add_import_bag(add)

    helping = add("help", help="show the help of beatlog or of one of its commands")
    helping.add_argument(
        "topic", nargs="?", choices=sorted(_COMMANDS), metavar="COMMAND", help="the command"
    )

    demo = add("demo", help="record and replay the robot dog, then its suite")
    demo.add_argument(
        "--duration",
        type=_positive_float,
        default=20.0,
        help="seconds to record (default: %(default)s)",
    )
    demo.add_argument(
        "--out",
        type=Path,
        default=Path("beatlog-demo"),
        help="the folder to keep the demo log in (default: %(default)s)",
    )
    return parser


def _add_export(add: Callable[..., argparse.ArgumentParser]) -> None:
    export_ = add(
        "export", help="write a session log as MCAP for Foxglove and Lichtblick, or a table"
    )
    export_.add_argument("log", help="the session log (.beatlog) to export: a path or a URL")
    export_.add_argument(
        "-o",
        "--output",
        required=True,
        type=Path,
        metavar="FILE",
        help="the file to write; its suffix picks the format: .mcap, .parquet or .csv",
    )
    export_.add_argument(
        "--format",
        choices=EXPORT_FORMATS,
        help="mcap (JSON messages, for viewers), parquet or csv (a row per cycle); "
        "default: the output's suffix, which must not name another format",
    )
    export_.add_argument(
        "--system",
        metavar="MODULE:FACTORY",
        help="also replay against this system and add its first divergence (MCAP only)",
    )


def _add_import_bag(add: Callable[..., argparse.ArgumentParser]) -> None:
    bag = add(
        "import-bag",
        help="turn a ROS bag into a session log with samples, replayable at sensor level",
    )
    bag.add_argument("bag", type=Path, help="the rosbag2 folder (mcap or sqlite3), or its file")
    bag.add_argument("-o", "--output", required=True, type=Path, help="the .beatlog to write")
    bag.add_argument("--system", required=True, metavar="MODULE:FACTORY", help="system factory")
    bag.add_argument(
        "--perception",
        required=True,
        metavar="MODULE:FACTORY",
        help="the perception step folding each heartbeat's messages into the robot state",
    )
    beats = bag.add_mutually_exclusive_group()
    beats.add_argument(
        "--period-ms",
        type=_positive_float,
        help="a heartbeat every this many ms from the first message imported (default: 30)",
    )
    beats.add_argument(
        "--clock-topic",
        metavar="TOPIC",
        help="a heartbeat at each message on this topic instead",
    )
    bag.add_argument(
        "--topic",
        action="append",
        dest="topics",
        default=[],
        metavar="TOPIC",
        help="import this topic (repeatable; default: every topic)",
    )
    bag.add_argument(
        "--spec",
        type=Path,
        metavar="FILE",
        help="also write a DTC spec (*.dtc.toml) that replays the log at sensor level",
    )
    bag.add_argument("--seed", type=int, help="seed of the random source (default: fresh)")
    bag.add_argument("--force", action="store_true", help="overwrite an existing log and spec")


def _import_bag(args: argparse.Namespace, console: Console) -> int:
    from beatlog.adapters.rosbag import import_bag

    output: Path = args.output
    _check_output(output)
    if args.spec is not None and args.spec.exists() and not args.force:
        raise _UsageError(f"{args.spec}: already exists (use --force)")
    try:
        imported = import_bag(
            args.bag,
            output,
            system=args.system,
            perception=args.perception,
            period_ns=None if args.period_ms is None else round(args.period_ms * 1e6),
            clock_topic=args.clock_topic,
            topics=args.topics,
            spec=args.spec,
            seed=args.seed,
            overwrite=args.force,
        )
    except LogExistsError:
        raise _UsageError(f"{output}: already exists (use --force)") from None
    console.print(imported.describe(), markup=False, highlight=False)
    return EXIT_OK


def _demo(args: argparse.Namespace, console: Console) -> int:
    """Run the demo a package registered under the ``beatlog.demo`` entry point group."""
    from importlib.metadata import entry_points

    demos = entry_points(group=DEMO_ENTRY_POINTS)
    if not demos:
        raise BeatlogError(
            "beatlog demo needs the example robots: pip install beatlog-examples "
            "(in a clone of beatlog: pip install -e examples)"
        )
    run_demo = next(iter(demos)).load()
    return int(run_demo(console, duration_s=args.duration, out=args.out))


def _add_test(test: argparse.ArgumentParser) -> None:
    """The options of ``beatlog test``."""
    test.add_argument(
        "paths",
        nargs="*",
        type=Path,
        default=[Path()],
        help="specs (*.dtc.toml) or folders searched for them (default: the current folder)",
    )
    where = test.add_mutually_exclusive_group()
    where.add_argument(
        "-j",
        "--jobs",
        type=_positive_int,
        help=f"processes replaying at once (default: the number of cores, {os.cpu_count() or 1})",
    )
    where.add_argument(
        "--dask",
        metavar="ADDRESS",
        help="run the DTCs on the Dask cluster whose scheduler is at ADDRESS "
        "(tcp://host:8786), or on one started here with local or local:N worker processes; "
        'specs on a filesystem the workers share (pip install "beatlog[dask]"); '
        "a cluster that cannot be reached exits 2",
    )
    test.add_argument(
        "-k",
        dest="select",
        metavar="EXPRESSION",
        help="only DTCs matching this expression, as pytest's -k: words matched against "
        "names and tags, with and, or, not and parentheses (e.g. -k 'touch or pat'); "
        "the names are the DTC's, its spec file's and its folders' below the rootdir",
    )
    test.add_argument(
        "--tag",
        action="append",
        default=[],
        help="only DTCs with this tag; given more than once, only DTCs with every tag given",
    )
    test.add_argument("--fail-fast", action="store_true", help="stop at the first failure")
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
        help="show which behavior states and transitions the DTCs exercise, and the states "
        "declared or seen by earlier runs (remembered in .beatlog_cache/) that none reaches",
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
        type=_shard,
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
    test.add_argument(
        "--system", metavar="MODULE:FACTORY", help="the system factory of a --logs run"
    )
    test.add_argument(
        "--perception",
        metavar="MODULE:FACTORY",
        help="the perception step of a --logs run: rebuild each robot state from the samples",
    )
    test.add_argument(
        "--break-at",
        type=_cycle_number,
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


def _shard(text: str) -> Shard:
    from beatlog.errors import OptionError
    from beatlog.suite.sharding import Shard

    try:
        return Shard.parse(text)
    except OptionError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _field_pair(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not (sep and name and value):
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE: {text!r}")
    return name, value


def _cycle_number(text: str) -> int:
    try:
        cycle = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a cycle number: {text!r}") from None
    if cycle < 0:
        raise argparse.ArgumentTypeError(f"must be 0 or more: {text!r}")
    return cycle


def _positive_float(text: str) -> float:
    return _positive(text, float, "a number")


def _positive_int(text: str) -> int:
    return _positive(text, int, "a whole number")


def _positive(text: str, kind: Callable[[str], Number], what: str) -> Number:
    try:
        value = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not {what}: {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be positive: {text!r}")
    return value


def _record(args: argparse.Namespace, console: Console) -> int:
    from beatlog.record.recorder import Recorder
    from beatlog.report.counts import plural
    from beatlog.usercode import load_robot, load_system

    robot = load_robot(args.robot)
    if args.system_ref:
        load_system(args.system_ref)  # replay will need it: a typo is found now, not then
    output: Path = args.output
    _check_output(output)
    interrupted = False
    try:
        recording = Recorder(
            output,
            robot.system,
            overwrite=args.force,
            robot_id=args.robot_id,
            system_ref=args.system_ref,
            period_ns=int(args.period_ms * 1e6),
            seed=args.seed,
            flush_interval_s=args.flush_interval,
            fsync=args.fsync,
            log_samples=args.log_samples,
        )
    except LogExistsError:
        raise _UsageError(
            f"{output}: already exists; recordings are immutable (use --force)"
        ) from None
    with recording as recorder:
        try:
            with _progress(console) as progress:
                total = int(args.duration * 1e3 / args.period_ms)
                task = progress.add_task("recording", total=total)
                recorder.run(
                    robot,
                    duration_s=args.duration,
                    on_cycle=lambda cycles: progress.update(task, completed=cycles),
                )
        except KeyboardInterrupt:  # the log is closed as it is; say what it holds
            interrupted = True
    line = (
        f"recorded {plural(recorder.cycles, 'cycle')} ({recorder.robot_time_ns / 1e9:.2f} s, "
        f"{recorder.overruns} overruns) to {output}"
    )
    if recorder.error is not None:
        line += f"; {_write_failure(output, recorder.error)}"
    console.print(line, markup=False, highlight=False)
    if interrupted:
        raise KeyboardInterrupt
    return EXIT_OK if recorder.error is None else EXIT_FAILED


def _check_output(output: Path) -> None:
    """Refuse a log to write before any work: its folder is missing, or it is a folder."""
    if not output.parent.is_dir():
        raise _UsageError(f"{output}: directory {output.parent} does not exist")
    if output.is_dir():
        raise _UsageError(f"{output}: is a directory")


def _prepare_report(report: Path) -> None:
    """Make a report's folder (as pytest's ``--junit-xml`` does) before any work, so that
    a report that cannot be written is found now, not after the whole suite."""
    if report.is_dir():
        raise _UsageError(f"{report}: is a directory")
    there = next(folder for folder in report.parents if folder.exists())
    if not there.is_dir():
        raise _UsageError(f"{report}: {there} is not a directory")
    try:
        report.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _UsageError(f"{report}: cannot write: {exc.strerror}") from None


def _write_failure(log: Path, error: str) -> str:
    """Where writing a log failed, as its first missing cycle read back from it."""
    from beatlog.analysis.summary import summarize

    try:
        kept = summarize(log).cycles
    except BeatlogError:
        return f"recording failed: {error} (the log cannot be read)"
    return f"recording failed at cycle {kept}: {error} (the log is valid up to there)"


def _progress(console: Console) -> Progress:
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed} cycles"),
        TimeElapsedColumn(),
        console=console,
        transient=True,
        disable=not console.is_terminal,  # a bar only where it can be redrawn, no blank line
    )


def _replay(args: argparse.Namespace, console: Console) -> int:
    import dataclasses

    import msgspec

    from beatlog.replay.debugger import break_on_divergence, unreached_break
    from beatlog.replay.judge import recorded_system
    from beatlog.replay.migration import StateMigration
    from beatlog.report.console import render_replay
    from beatlog.suite.approved import replay

    given = args.log
    with _readable(args) as named:
        if args.break_at is not None:
            _check_break(args.break_at, Path(args.log))
        system = args.system
        if system is None:
            system = recorded_system(args.log)
            print(
                f"beatlog: replaying against {system}, as recorded in {given} "
                "and listed in the project's [tool.beatlog] systems",
                file=sys.stderr,
            )
        options = {
            "keep_going": args.keep_going,
            "allow_truncated": args.allow_truncated,
            "allow_empty": args.allow_empty,
            "perception": args.perception,
            "approved": not args.recording,
            "migration": StateMigration(dict(args.rename_field), dict(args.convert_field)),
        }
        result = replay(args.log, system, break_at=args.break_at, **options)
        notes = unreached_break(args.break_at, result)
        if args.break_on_divergence:
            notes += break_on_divergence(
                result, lambda cycle: replay(args.log, system, break_at=cycle, **options)
            )
        result = dataclasses.replace(result, notes=result.notes + notes)
    if named is not None:
        result = dataclasses.replace(result, url=given, reproduce=named(result.reproduce))
    if args.json:
        sys.stdout.write(msgspec.json.encode(result, enc_hook=str).decode() + "\n")
    else:
        console.print(render_replay(result))
    return EXIT_OK if result.ok else EXIT_FAILED


def _check_break(break_at: int, log: Path) -> None:
    """A break past the end of the log, as its end record counts its cycles, is a usage
    error before anything replays."""
    from beatlog.replay.debugger import beyond_the_log

    problem = beyond_the_log(break_at, log)
    if problem is not None:
        raise _UsageError(f"--break-at {break_at}: {problem}")


def _break_points(args: argparse.Namespace, specs: list[DtcSpec]) -> bool:
    """Whether the run stops in the debugger; a break it cannot make is a usage error:
    ``--break-at`` with more than one DTC or past the end of its log, any with --dask."""
    if args.break_at is not None:
        if len(specs) > 1:
            raise _UsageError(
                f"--break-at stops in one DTC, and {len(specs)} are selected: "
                "name its spec or select it with -k"
            )
        if specs[0].log_url is None:
            _check_break(args.break_at, specs[0].log)
    breaking = args.break_at is not None or args.break_on_divergence
    if breaking and args.dask is not None:
        raise _UsageError("break points stop in this process: leave out --dask")
    return bool(breaking)


def _selected_specs(
    args: argparse.Namespace, fleet: list[DtcSpec] | None = None
) -> tuple[list[DtcSpec], list[DtcSpec]]:
    """The specs found under the paths (or those of a fleet run's logs), and those
    ``beatlog test`` runs: selected by -k and --tag, and of those the shard's share,
    those that share a name named by their ids."""
    from beatlog.suite.spec import discover_specs, distinguished, find_rootdir, select_specs

    found = discover_specs(args.paths) if fleet is None else fleet
    rootdir = find_rootdir(args.paths) if fleet is None else None
    specs = select_specs(found, pattern=args.select, tags=args.tag, rootdir=rootdir)
    if specs and args.behavior is not None:
        from beatlog.suite.coverage import select_exercising

        specs = select_exercising(specs, args.behavior)
    if not specs:
        where = " ".join(str(path) for path in args.paths) if fleet is None else args.logs
        if found:
            raise _UsageError(f"none of the {len(found)} DTC specs in {where} match -k/--tag")
        raise _UsageError(f"no DTC specs to run in {where} (looked for *.dtc.toml)")
    if args.shard is not None:
        from beatlog.suite.sharding import shard

        specs = shard(specs, args.shard.index, args.shard.count)
    return found, distinguished(specs)


def _write_json(path: Path, document: object) -> None:
    """Write a JSON document whole or not at all; an unwritable path is bad input."""
    from beatlog.files import write_json

    try:
        write_json(path, document)
    except OSError as exc:
        raise _UsageError(f"{path}: cannot write: {exc.strerror}") from None


def _test_exit_code(outcomes: list[SpecOutcome]) -> int:
    """2 when a DTC could not run, 1 when one failed or the audit found something, else 0."""
    from beatlog.suite.runner import Verdict

    counts = Counter(outcome.verdict for outcome in outcomes)
    if counts[Verdict.ERROR]:
        return EXIT_USAGE
    unsound = any(outcome.audit_findings for outcome in outcomes)
    return EXIT_FAILED if counts[Verdict.FAILED] or unsound else EXIT_OK


def _test(args: argparse.Namespace, console: Console) -> int:
    if args.logs is None:
        if args.system is not None or args.perception is not None:
            raise _UsageError("--system and --perception go with --logs: a spec names its own")
        return _run_tests(args, console)
    from beatlog.suite.fleet import check_references, fleet_specs

    if args.system is None:
        raise _UsageError("--logs needs --system MODULE:FACTORY to replay the logs against")
    if args.paths != [Path()]:
        raise _UsageError("give DTC specs or --logs, not both")
    if args.update is not UpdateMode.NONE:
        raise _UsageError("--update writes the baselines of specs; --logs runs have none")
    fleet = fleet_specs(args.logs, system=args.system, perception=args.perception)
    check_references(fleet[0])
    return _run_tests(args, console, fleet)


def _run_tests(
    args: argparse.Namespace, console: Console, fleet: list[DtcSpec] | None = None
) -> int:
    """Run the specs, or a fleet run's logs, as ``beatlog test`` does."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from beatlog.report.console import render_suite
    from beatlog.report.counts import verdict_counts
    from beatlog.suite.runner import Verdict, run_suite

    for report in (args.junit_xml, args.html, args.coverage_json):
        if report is not None:
            _prepare_report(report)
    found, specs = _selected_specs(args, fleet)
    breaking = _break_points(args, specs)
    progress = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total} DTCs"),
        TextColumn("{task.fields[rate]}"),
        TimeElapsedColumn(),
        console=console,
        transient=True,
        # a bar only where it can be redrawn (no blank line), and never under a debugger
        disable=not console.is_terminal or breaking,
    )
    started = time.perf_counter()
    cycles = 0
    finished: dict[Path, SpecOutcome] = {}

    def on_outcome(outcome: SpecOutcome) -> None:
        nonlocal cycles
        finished[outcome.spec.path] = outcome
        cycles += outcome.result.cycles if outcome.result else 0
        rate = f"{cycles / max(time.perf_counter() - started, 1e-9):,.0f} cycles/s"
        progress.update(task, advance=1, rate=rate)
        if outcome.verdict is Verdict.ERROR:
            _error(
                f"{outcome.spec.label} ({outcome.spec.origin}): {outcome.error}",
                outcome.error_traceback if args.verbose else None,
            )
        elif outcome.verdict is Verdict.FAILED or args.verbose:
            progress.console.print(_describe(outcome))
        if outcome.retries:
            progress.console.print(
                f"retried {outcome.spec.label}: the worker replaying it died "
                f"({outcome.retries} time{'s' if outcome.retries > 1 else ''})",
                markup=False,
                highlight=False,
            )

    interrupted: KeyboardInterrupt | None = None
    try:
        with _executor(args.dask) as executor, progress:
            task = progress.add_task("replaying", total=len(specs), rate="")
            run_suite(
                specs,
                jobs=args.jobs or os.cpu_count() or 1,
                fail_fast=args.fail_fast,
                update=args.update,
                audit=args.audit,
                timelines=args.html is not None,
                on_outcome=on_outcome,
                break_at=args.break_at,
                break_on_divergence=args.break_on_divergence,
                executor=executor,
            )
    except KeyboardInterrupt as stop:  # report what is complete, then write nothing
        interrupted = stop
    wall = time.perf_counter() - started
    outcomes = [finished[spec.path] for spec in specs if spec.path in finished]
    if outcomes:
        console.print(render_suite(outcomes, every=args.verbose))
        _print_notes(outcomes, console)
        if args.audit:
            from beatlog.report.audit import render_audit

            console.print(render_audit(outcomes))
    if interrupted is None:
        _write_reports(args, outcomes, console, {spec.id: spec.name for spec in found})
    skipped = len(specs) - len(outcomes)
    console.print(
        verdict_counts(
            (outcome.verdict for outcome in outcomes),
            not_run=skipped,
            open_loop=sum(outcome.open_loop is not None for outcome in outcomes),
        )
        + f" in {wall:.2f} s ({cycles:,} cycle{'' if cycles == 1 else 's'})"
    )
    if interrupted is not None:
        raise interrupted
    return _test_exit_code(outcomes)


def _print_notes(outcomes: list[SpecOutcome], console: Console) -> None:
    """What the passing DTCs' replays note (a failure's report has its own), one line
    per note, naming a few of the DTCs it concerns."""
    from beatlog.suite.runner import Verdict

    concerned: dict[str, list[str]] = {}
    for outcome in outcomes:
        if outcome.verdict is Verdict.PASSED and outcome.result is not None:
            for note in outcome.result.notes:
                concerned.setdefault(note, []).append(outcome.spec.label)
    for note, names in concerned.items():
        shown = ", ".join(names[:_NAMED_IN_NOTES])
        if len(names) > _NAMED_IN_NOTES:
            shown = f"{len(names)} DTCs ({shown} and {len(names) - _NAMED_IN_NOTES} more)"
        console.print(f"note: {shown}: {note}", markup=False, highlight=False)


def _executor(address: str | None) -> AbstractContextManager[DaskExecutor | None]:
    """The Dask cluster of ``--dask``, connected to (or started) for the run; none without."""
    if address is None:
        return contextlib.nullcontext()
    from beatlog.suite.cluster import DaskExecutor

    return DaskExecutor(address)


def _write_reports(
    args: argparse.Namespace,
    outcomes: list[SpecOutcome],
    console: Console,
    suite: dict[str, str],
) -> None:
    """Pending baselines, orphans, JUnit and HTML: only for a suite that ran to its end.
    ``suite`` names every DTC found, selected or not, by its id (the coverage memory's
    due)."""
    from beatlog.cli.baselines import report_orphans, show_updates
    from beatlog.report.console import plain_text
    from beatlog.suite.junit import write_junit
    from beatlog.suite.maintenance import update_baselines

    show_updates(update_baselines(outcomes, args.update), console)
    if args.logs is None:
        report_orphans(args.paths, console)
    if args.junit_xml is not None:
        try:
            write_junit(args.junit_xml, outcomes, describe=lambda o: plain_text(_describe(o)))
        except OSError as exc:
            raise _UsageError(f"{args.junit_xml}: cannot write: {exc.strerror}") from None
    coverage = None
    if args.coverage or args.coverage_json is not None:
        from beatlog.report.coverage import render_coverage
        from beatlog.suite.coverage import suite_coverage

        coverage = suite_coverage([outcome.spec for outcome in outcomes])
        if args.logs is None:
            from beatlog.suite.coverage_cache import cache_path, recall
            from beatlog.suite.spec import find_rootdir

            warning = recall(coverage, cache_path(find_rootdir(args.paths)), suite).warning
            if warning is not None:
                print(f"beatlog: warning: {warning}", file=sys.stderr)
        if args.coverage:
            console.print(render_coverage(coverage))
        if args.coverage_json is not None:
            _write_json(args.coverage_json, coverage.to_json())
    if args.html is not None:
        from beatlog.report.html import write_html

        try:
            write_html(outcomes, args.html, coverage=coverage)
        except OSError as exc:
            raise _UsageError(f"{args.html}: cannot write: {exc.strerror}") from None


def _describe(outcome: SpecOutcome) -> RenderableType:
    """A DTC's outcome: one line for an error or a pass (what it checked), the first
    divergence for a failure."""
    from rich.console import Group
    from rich.text import Text

    from beatlog.report.console import render_passed, render_replay
    from beatlog.suite.runner import Verdict

    if outcome.verdict is Verdict.PASSED:
        return render_passed(outcome)
    if outcome.result is None:
        return Text.assemble(("ERROR ", "bold magenta"), f"{outcome.spec.label}: {outcome.error}")
    return Group(
        Text.assemble(("DTC ", "bold"), f"{outcome.spec.label} ({outcome.spec.origin})"),
        render_replay(outcome.result),
    )


def _show(args: argparse.Namespace, console: Console) -> int:
    import dataclasses

    from beatlog.analysis.summary import summarize
    from beatlog.report.baselines import render_approved
    from beatlog.report.console import render_summary
    from beatlog.suite.approved import approved_baselines

    given = args.log
    with _readable(args) as named:
        summary = summarize(args.log)
        approved = [] if named is not None else approved_baselines(args.log)
    if named is not None:
        summary = dataclasses.replace(summary, url=given)
    console.print(render_summary(summary))
    for baseline in approved:
        console.print(render_approved(baseline))
    return EXIT_OK


def _plot(args: argparse.Namespace, console: Console) -> int:
    _need_matplotlib("plot")
    from beatlog.analysis.timeline import build_timeline
    from beatlog.replay.judge import replay
    from beatlog.report.chart import chart_format, write_chart

    chart_format(args.output)  # an unknown suffix is refused before anything runs
    given = args.log
    with _readable(args):
        divergence = (
            None
            if args.system is None
            else replay(args.log, args.system, allow_empty=True).divergence
        )
        timeline = build_timeline(args.log, args.system, fields=args.fields, divergence=divergence)
    try:
        write_chart(timeline, args.output)
    except OSError as exc:
        raise _UsageError(f"{args.output}: cannot write: {exc.strerror}") from None
    mark = timeline.divergence
    console.print(
        f"drew {timeline.cycles} cycles of {given} to {args.output}"
        + ("" if mark is None else f"; first divergence at cycle {mark.cycle} ({mark.kind})"),
        markup=False,
        highlight=False,
    )
    return EXIT_OK


def _export(args: argparse.Namespace, console: Console) -> int:
    import dataclasses

    from beatlog.adapters.export import export, export_format

    chosen = export_format(args.output, args.format)  # refused before anything runs
    given = args.log
    with _readable(args) as named:
        result = export(args.log, args.output, format=chosen, system=args.system)
    if named is not None:
        result = dataclasses.replace(result, url=given)
    console.print(result.describe(), markup=False, highlight=False)
    return EXIT_OK if result.divergence is None else EXIT_FAILED


@contextlib.contextmanager
def _readable(args: argparse.Namespace) -> Iterator[Callable[[str], str] | None]:
    """``args.log`` as a file of this machine while the block runs: a log behind a URL
    is copied once (:func:`beatlog.remote.fetched_log`, with a progress bar on a
    terminal) and ``args.log`` names the copy, which is removed after. The block is
    given a function that names the copy by its URL in a text, and errors raised in it
    are named so too; None for a local log."""
    from beatlog.remote import fetched_log, is_url, named_as_given

    url = str(args.log)
    if not is_url(url):
        yield None
        return
    with fetched_log(url, progress=True) as copy:
        args.log = copy
        try:
            yield functools.partial(named_as_given, copy=copy, url=url)
        except BeatlogError as exc:
            exc.args = (named_as_given(str(exc), copy, url),)
            raise


def _need_matplotlib(command: str) -> None:
    """Charts need the optional ``plot`` extra; say so in one line when it is missing."""
    try:
        import matplotlib  # noqa: F401
    except ModuleNotFoundError:
        raise _UsageError(f'{command} needs matplotlib (pip install "beatlog[plot]")') from None


def _import_from_working_directory() -> None:
    """Let MODULE:FACTORY name a module of the working directory, as ``python -m`` does.

    The console script's ``sys.path`` starts with its own bin directory, so without
    this ``beatlog replay x.beatlog --system tests.robot:system`` (the reproduce
    command replay prints) fails to import from a project's root.
    """
    cwd = os.getcwd()
    if "" not in sys.path and cwd not in sys.path:
        sys.path.insert(0, cwd)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit code (the console script exits with it)."""
    verbose = False
    with _terminated_as_interrupted() as terminated:
        try:
            args = _parser().parse_args(argv)
            verbose = args.verbose
            from rich.console import Console

            console = Console(soft_wrap=True)  # long commands stay one line, for copy and paste
            run, runs_user_code = _COMMANDS[args.command]
            if runs_user_code:
                _import_from_working_directory()
            return run(args, console)
        except BeatlogError as exc:
            _error(str(exc), exc.user_traceback if verbose else None)
            return EXIT_USAGE
        except KeyboardInterrupt as stop:
            if terminated.is_set():
                print("beatlog: terminated", file=sys.stderr)
                return EXIT_TERMINATED
            print(f"beatlog: {_interruption(stop)}", file=sys.stderr)
            return EXIT_INTERRUPTED


def _interruption(stop: KeyboardInterrupt) -> str:
    """What stopped the command: Ctrl-C, or the debugger quit at a break (which says so).
    Nothing is imported on the way out: a break imported the debugger where there was one."""
    debugger = sys.modules.get("beatlog.replay.debugger")
    if debugger is not None and isinstance(stop, debugger.DebuggerQuit):
        return str(stop)
    return "interrupted"


@contextlib.contextmanager
def _terminated_as_interrupted() -> Iterator[threading.Event]:
    """While the block runs, SIGTERM stops the command as Ctrl-C does (a
    ``KeyboardInterrupt``, so what it holds is cleaned up: a log closed, downloaded
    copies removed); the event given is set once it came. Only the main thread can
    handle signals: elsewhere SIGTERM is left as it is."""
    terminated = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield terminated
        return

    def interrupt(signum: int, frame: FrameType | None) -> None:
        terminated.set()
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield terminated
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


def _help(args: argparse.Namespace, console: Console) -> int:
    """``beatlog help [COMMAND]``: the help page ``--help`` prints."""
    _parser().parse_args([*([args.topic] if args.topic else []), "--help"])
    return EXIT_OK


def _review(args: argparse.Namespace, console: Console) -> int:
    from beatlog.cli.baselines import review

    review(args.paths, console)
    return EXIT_OK


def _approve(args: argparse.Namespace, console: Console) -> int:
    from beatlog.cli.baselines import approve_command

    approve_command(args.paths, console)
    return EXIT_OK


Command = Callable[[argparse.Namespace, "Console"], int]
_COMMANDS: dict[str, tuple[Command, bool]] = {
    "record": (_record, True),
    "replay": (_replay, True),
    "test": (_test, True),
    "show": (_show, False),
    "review": (_review, True),
    "approve": (_approve, True),
    "plot": (_plot, True),
    "export": (_export, True),
    "import-bag": (_import_bag, True),
    "demo": (_demo, False),
    "help": (_help, False),
}
"""Each subcommand's handler, and whether it imports the user's code (``module:factory``)."""


def _error(problem: str, user_traceback: str | None = None) -> None:
    """One line on stderr; with ``--verbose`` the user's traceback before it."""
    if user_traceback:
        sys.stderr.write(user_traceback)
    print(f"beatlog: error: {problem}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
