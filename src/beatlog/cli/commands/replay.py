"""``beatlog replay``: replay a session log and give a verdict."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from beatlog.cli.common import (
    EXIT_FAILED,
    EXIT_OK,
    add_factory,
    add_invariants,
    add_log,
    cycle_number,
    field_pair,
    readable,
)
from beatlog.errors import OptionError

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["add_arguments", "run"]


def add_arguments(play: argparse.ArgumentParser) -> None:
    """The options of ``beatlog replay``."""
    add_log(play, "replay")
    add_factory(
        play,
        "--system",
        "system factory (default: the one the log records, from record --system-ref, "
        "where the project lists it under [tool.beatlog] systems in pyproject.toml)",
    )
    add_factory(
        play,
        "--perception",
        "rebuild each robot state from the logged samples with this perception step",
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
        type=cycle_number,
        metavar="CYCLE",
        help="stop in the debugger just before the behaviors update in this cycle",
    )
    play.add_argument(
        "--break-on-divergence",
        action="store_true",
        help="replay again and stop in the debugger at the first divergence",
    )
    play.add_argument(
        "--start-cycle",
        type=cycle_number,
        default=0,
        metavar="CYCLE",
        help="judge from this cycle on: the cycles before it replay as recorded, unjudged",
    )
    play.add_argument(
        "--end-cycle",
        type=cycle_number,
        metavar="CYCLE",
        help="judge up to this cycle (inclusive) and read the log no further",
    )
    play.add_argument(
        "--fresh-start",
        action="store_true",
        help="start the behaviors from rest at --start-cycle: the cycles before it are "
        "not replayed",
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
        type=field_pair,
        default=[],
        metavar="OLD=NEW",
        help="a robot-state field renamed since the recording (a dotted path inside a "
        "struct); repeat for more",
    )
    play.add_argument(
        "--convert-field",
        action="append",
        type=field_pair,
        default=[],
        metavar="FIELD=MODULE:FUNCTION",
        help="a robot-state field retyped since the recording, and the function that "
        "converts its recorded value; repeat for more",
    )
    add_invariants(play, "replayed")
    play.add_argument("--json", action="store_true", help="print the result as JSON")


def run(args: argparse.Namespace, console: Console) -> int:
    """Replay the log; its verdict, as text or JSON."""
    import dataclasses

    import msgspec

    from beatlog.replay.debugger import beyond_the_log, break_on_divergence, unreached_break
    from beatlog.replay.fit.migration import StateMigration
    from beatlog.replay.setup import recorded_system
    from beatlog.report.console import render_replay
    from beatlog.suite.approved import replay

    if args.end_cycle is not None and args.start_cycle > args.end_cycle:
        raise OptionError(f"--start-cycle {args.start_cycle} is after --end-cycle {args.end_cycle}")
    with readable(args) as url:
        problem = None if args.break_at is None else beyond_the_log(args.break_at, Path(args.log))
        if problem is not None:  # a break past the end of the log, as its end record counts
            raise OptionError(f"--break-at {args.break_at}: {problem}")
        system = args.system
        if system is None:
            system = recorded_system(args.log)
            print(
                f"beatlog: replaying against {system}, as recorded in {url or args.log} "
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
            "start_cycle": args.start_cycle,
            "end_cycle": args.end_cycle,
            "fresh_start": args.fresh_start,
            "invariants": args.invariants,
        }
        result = replay(args.log, system, break_at=args.break_at, **options)
        notes = unreached_break(args.break_at, result)
        if args.break_on_divergence:
            notes += break_on_divergence(
                result, lambda cycle: replay(args.log, system, break_at=cycle, **options)
            )
        result = dataclasses.replace(result, notes=result.notes + notes)
    if url is not None:
        reproduce = result.reproduce.replace(str(args.log), url)
        result = dataclasses.replace(result, url=url, reproduce=reproduce)
    if args.json:
        sys.stdout.write(msgspec.json.encode(result, enc_hook=str).decode() + "\n")
    else:
        console.print(render_replay(result))
    return EXIT_OK if result.ok else EXIT_FAILED
