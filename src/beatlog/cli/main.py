"""The ``beatlog`` command: a thin shell over the library.

Exit codes: 0 pass, 1 a replay diverged or a recording failed, 2 usage error or bad
input (one line on stderr naming the file and the problem, never a traceback).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NoReturn, TypeVar

import msgspec
from rich.console import Console, Group, RenderableType
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.text import Text

from beatlog._version import __version__
from beatlog.cli.baselines import approve, report_orphans, review, write_pending
from beatlog.engine.loading import load_factory
from beatlog.engine.record import Recorder
from beatlog.engine.replay import replay
from beatlog.engine.timeline import build_timeline
from beatlog.errors import BeatlogError
from beatlog.log.summary import summarize
from beatlog.model.robot import Robot
from beatlog.report.audit import render_audit
from beatlog.report.console import plain_text, render_replay, render_suite, render_summary
from beatlog.suite.junit import write_junit
from beatlog.suite.runner import SpecOutcome, Verdict, run_suite
from beatlog.suite.spec import discover_specs, select_specs

__all__ = ["main"]

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2
Number = TypeVar("Number", int, float)


class _UsageError(BeatlogError):
    """A bad option or argument."""


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error in one line and exit code 2."""

    def error(self, message: str) -> NoReturn:
        raise _UsageError(f"{message} (see '{self.prog} --help')")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="beatlog",
        description="Record robot sessions and replay them as deterministic test cases.",
    )
    parser.add_argument("--version", action="version", version=f"beatlog {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    record = commands.add_parser("record", help="run a robot in real time and record a session")
    record.add_argument("--robot", required=True, metavar="MODULE:FACTORY", help="robot factory")
    record.add_argument("-o", "--output", required=True, type=Path, help="the .beatlog to write")
    record.add_argument(
        "--duration", type=_positive_float, required=True, help="robot time to record (s)"
    )
    record.add_argument("--period-ms", type=_positive_float, default=30.0, help="heartbeat period")
    record.add_argument("--seed", type=int, help="seed of the random source (default: fresh)")
    record.add_argument("--robot-id", default="robot", help="name of the robot in the header")
    record.add_argument(
        "--system-ref",
        default="",
        metavar="MODULE:FACTORY",
        help="the system factory replay should use, written into the header",
    )
    record.add_argument("--log-samples", action="store_true", help="also log raw sensor samples")
    record.add_argument(
        "--flush-interval", type=_positive_float, default=1.0, help="seconds between flushes"
    )
    record.add_argument("--fsync", action="store_true", help="fsync at every flush")
    record.add_argument("--force", action="store_true", help="overwrite an existing log")

    play = commands.add_parser("replay", help="replay a session log and give a verdict")
    play.add_argument("log", type=Path)
    play.add_argument("--system", required=True, metavar="MODULE:FACTORY", help="system factory")
    play.add_argument("--keep-going", action="store_true", help="count every diverging cycle")
    play.add_argument("--allow-truncated", action="store_true", help="pass a log that was cut off")
    play.add_argument("--json", action="store_true", help="print the result as JSON")

    test = commands.add_parser("test", help="run DTC specs (*.dtc.toml) in parallel")
    test.add_argument("paths", nargs="*", type=Path, default=[Path()], help="specs or folders")
    test.add_argument(
        "-j", "--jobs", type=_positive_int, default=os.cpu_count() or 1, help="worker processes"
    )
    test.add_argument("-k", dest="select", metavar="NAME", help="only DTCs whose name matches")
    test.add_argument(
        "--tag", action="append", default=[], help="only DTCs with this tag (repeatable)"
    )
    test.add_argument("--fail-fast", action="store_true", help="stop at the first failure")
    test.add_argument("--junit-xml", type=Path, metavar="FILE", help="write a JUnit report")
    test.add_argument(
        "--html", type=Path, metavar="FILE", help="write an HTML report with timeline charts"
    )
    test.add_argument(
        "--update",
        action="store_true",
        help="write the new state changes of failed DTCs to pending files for review",
    )
    test.add_argument(
        "--audit",
        action="store_true",
        help="also replay each DTC twice with different hash seeds, watching for wall-clock "
        "reads and global random calls",
    )

    check = commands.add_parser("review", help="show pending baseline changes; accept or reject")
    check.add_argument("paths", nargs="*", type=Path, default=[Path()], help="specs or folders")
    accept = commands.add_parser("approve", help="accept the pending baselines of DTC specs")
    accept.add_argument("paths", nargs="+", type=Path, help="specs or folders")

    show = commands.add_parser("show", help="describe a session log")
    show.add_argument("log", type=Path)

    plot = commands.add_parser("plot", help="draw a PNG timeline of a session log")
    plot.add_argument("log", type=Path)
    plot.add_argument("-o", "--output", required=True, type=Path, metavar="FILE.png")
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

    demo = commands.add_parser("demo", help="record and replay the robot dog, then its suite")
    demo.add_argument("--duration", type=_positive_float, default=20.0, help="seconds to record")
    demo.add_argument(
        "--out", type=Path, default=Path("beatlog-demo"), help="where to keep the demo log"
    )
    return parser


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
    robot = load_factory(args.robot)
    if not isinstance(robot, Robot):
        raise _UsageError(f"{args.robot!r}: built a {type(robot).__name__}, not a robot")
    output: Path = args.output
    if output.exists() and not args.force:
        raise _UsageError(f"{output}: already exists; recordings are immutable (use --force)")
    if not output.parent.is_dir():
        raise _UsageError(f"{output}: directory {output.parent} does not exist")
    with (
        Recorder(
            output,
            robot.system,
            robot_id=args.robot_id,
            system_ref=args.system_ref,
            period_ns=int(args.period_ms * 1e6),
            seed=args.seed,
            flush_interval_s=args.flush_interval,
            fsync=args.fsync,
            log_samples=args.log_samples,
        ) as recorder,
        _progress(console) as progress,
    ):
        total = int(args.duration * 1e3 / args.period_ms)
        task = progress.add_task("recording", total=total)
        summary = recorder.run(
            robot,
            duration_s=args.duration,
            on_cycle=lambda cycles: progress.update(task, completed=cycles),
        )
    console.print(
        f"recorded {summary.cycles} cycles ({summary.robot_time_ns / 1e9:.2f} s, "
        f"{summary.overruns} overruns) to {output}"
    )
    if summary.error is not None:
        console.print(f"[red]recording failed: {summary.error}; the log is valid up to there")
        return EXIT_FAILED
    return EXIT_OK


def _progress(console: Console) -> Progress:
    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed} cycles"),
        TimeElapsedColumn(),
        console=console,
        transient=True,
    )


def _replay(args: argparse.Namespace, console: Console) -> int:
    result = replay(
        args.log, args.system, keep_going=args.keep_going, allow_truncated=args.allow_truncated
    )
    if args.json:
        sys.stdout.write(msgspec.json.encode(result, enc_hook=str).decode() + "\n")
    else:
        console.print(render_replay(result))
    return EXIT_OK if result.ok else EXIT_FAILED


def _test(args: argparse.Namespace, console: Console) -> int:
    found = discover_specs(args.paths)
    specs = select_specs(found, pattern=args.select, tags=args.tag)
    if not specs:
        where = " ".join(str(path) for path in args.paths)
        if found:
            raise _UsageError(f"none of the {len(found)} DTC specs in {where} match -k/--tag")
        raise _UsageError(f"no DTC specs to run in {where} (looked for *.dtc.toml)")
    progress = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total} DTCs"),
        TextColumn("{task.fields[rate]}"),
        TimeElapsedColumn(),
        console=console,
        transient=True,
    )
    started = time.perf_counter()
    cycles = 0

    def report(outcome: SpecOutcome) -> None:
        nonlocal cycles
        cycles += outcome.result.cycles if outcome.result else 0
        rate = f"{cycles / max(time.perf_counter() - started, 1e-9):,.0f} cycles/s"
        progress.update(task, advance=1, rate=rate)
        if outcome.verdict is not Verdict.PASSED:
            progress.console.print(_describe(outcome))

    if args.html is not None:
        _need_matplotlib("test --html")
    with progress:
        task = progress.add_task("replaying", total=len(specs), rate="")
        outcomes = run_suite(
            specs,
            jobs=args.jobs,
            fail_fast=args.fail_fast,
            update=args.update,
            audit=args.audit,
            timelines=args.html is not None,
            on_outcome=report,
        )
    wall = time.perf_counter() - started
    console.print(render_suite(outcomes))
    if args.audit:
        console.print(render_audit(outcomes))
    if args.update:
        write_pending(outcomes, console)
    report_orphans(args.paths, console)
    if args.junit_xml is not None:
        try:
            write_junit(args.junit_xml, outcomes, describe=lambda o: plain_text(_describe(o)))
        except OSError as exc:
            raise _UsageError(f"{args.junit_xml}: cannot write: {exc.strerror}") from None
    if args.html is not None:
        from beatlog.report.html import write_html  # noqa: PLC0415 - matplotlib is optional

        try:
            write_html(outcomes, args.html)
        except OSError as exc:
            raise _UsageError(f"{args.html}: cannot write: {exc.strerror}") from None
    counts = Counter(outcome.verdict for outcome in outcomes)
    skipped = len(specs) - len(outcomes)
    console.print(
        f"{counts[Verdict.PASSED]} passed, {counts[Verdict.FAILED]} failed"
        + _plural(counts[Verdict.ERROR], "error")
        + (f", {skipped} not run" if skipped else "")
        + f" in {wall:.2f} s ({cycles:,} cycles)"
    )
    if counts[Verdict.ERROR]:
        return EXIT_USAGE
    unsound = any(outcome.audit_findings for outcome in outcomes)
    return EXIT_FAILED if counts[Verdict.FAILED] or unsound else EXIT_OK


def _plural(count: int, noun: str) -> str:
    return f", {count} {noun}{'' if count == 1 else 's'}" if count else ""


def _describe(outcome: SpecOutcome) -> RenderableType:
    if outcome.result is None:
        return Text.assemble(("ERROR ", "bold magenta"), f"{outcome.spec.name}: {outcome.error}")
    return Group(
        Text.assemble(("DTC ", "bold"), f"{outcome.spec.name} ({outcome.spec.path})"),
        render_replay(outcome.result),
    )


def _show(args: argparse.Namespace, console: Console) -> int:
    console.print(render_summary(summarize(args.log)))
    return EXIT_OK


def _plot(args: argparse.Namespace, console: Console) -> int:
    _need_matplotlib("plot")
    from beatlog.report.chart import write_png  # noqa: PLC0415 - matplotlib is optional

    timeline = build_timeline(args.log, args.system, fields=args.fields)
    try:
        write_png(timeline, args.output)
    except OSError as exc:
        raise _UsageError(f"{args.output}: cannot write: {exc.strerror}") from None
    mark = timeline.divergence
    console.print(
        f"drew {timeline.cycles} cycles of {args.log} to {args.output}"
        + ("" if mark is None else f"; first divergence at cycle {mark.cycle} ({mark.kind})"),
        markup=False,
        highlight=False,
    )
    return EXIT_OK


def _need_matplotlib(command: str) -> None:
    """Charts need the optional ``plot`` extra; say so in one line when it is missing."""
    try:
        import matplotlib  # noqa: F401, PLC0415
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
    console = Console(soft_wrap=True)  # long commands stay one line, for copy and paste
    try:
        args = _parser().parse_args(argv)
        if args.command in ("record", "replay", "test", "review", "approve", "plot"):
            _import_from_working_directory()
        if args.command == "record":
            return _record(args, console)
        if args.command == "replay":
            return _replay(args, console)
        if args.command == "test":
            return _test(args, console)
        if args.command == "show":
            return _show(args, console)
        if args.command == "review":
            review(args.paths, console)
            return EXIT_OK
        if args.command == "approve":
            approve(args.paths, console)
            return EXIT_OK
        if args.command == "plot":
            return _plot(args, console)
        from beatlog.cli.demo import run_demo  # noqa: PLC0415 - only the demo needs MuJoCo

        return run_demo(console, duration_s=args.duration, out=args.out)
    except BeatlogError as exc:
        print(f"beatlog: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("beatlog: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
