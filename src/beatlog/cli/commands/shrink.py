"""``beatlog shrink``: the shortest window of cycles, and the fewest perturbations, that
still fail a DTC the same way, written as a spec beside it."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from beatlog.cli.common import EXIT_FAILED, EXIT_OK, progress

if TYPE_CHECKING:
    from rich.console import Console

    from beatlog.suite.shrink import Shrunk

__all__ = ["add_arguments", "run"]


def add_arguments(shrink: argparse.ArgumentParser) -> None:
    """The arguments of ``beatlog shrink``."""
    shrink.add_argument(
        "spec",
        type=Path,
        help="the failing DTC spec (.dtc.toml); NAME.shrunk.dtc.toml is written beside it",
    )


def run(args: argparse.Namespace, console: Console) -> int:
    """Shrink the spec; what it found in a few lines, or one line where it passes."""
    from beatlog.suite.shrink import Attempt, NothingToShrinkError, shrink

    with progress(console, "{task.completed} replays", "{task.fields[window]}") as bar:
        task = bar.add_task(f"shrinking {args.spec.name}", total=None, window="")

        def tried(attempt: Attempt) -> None:
            end = "end" if attempt.end_cycle is None else attempt.end_cycle
            fresh = ", fresh start" if attempt.fresh_start else ""
            window = f"cycles {attempt.start_cycle}-{end}{fresh}"
            bar.update(task, completed=attempt.replays, window=window)

        try:
            shrunk = shrink(args.spec, progress=tried)
        except NothingToShrinkError as passes:
            console.print(str(passes), highlight=False, markup=False)
            return EXIT_FAILED
    _report(shrunk, console)
    return EXIT_OK


def _report(shrunk: Shrunk, console: Console) -> None:
    """What the shrink found: the failure, the window against the cycles before, the
    perturbations left, the replays tried and the spec written."""
    failure = shrunk.failure
    where = f" {failure.invariant}" if failure.invariant else ""
    where = where or (f" in {failure.behavior}" if failure.behavior else "")
    start = shrunk.start_cycle
    before = f", {start} replayed before it" if start else ""
    lines = [
        f"shrunk {failure.kind.value}{where} at cycle {failure.cycle}: "
        f"{shrunk.cycles_before} cycles to the failure -> window {start}-{shrunk.end_cycle} "
        f"({shrunk.cycles_judged} judged{', fresh start' if shrunk.fresh_start else before})",
        f"replays tried: {shrunk.replays}",
        f"wrote {shrunk.path} (beatlog test {shrunk.path})",
    ]
    if shrunk.perturbations_before:
        kept = f" ({', '.join(shrunk.perturbations)})" if shrunk.perturbations else ""
        before_after = f"{len(shrunk.perturbations_before)} -> {len(shrunk.perturbations)}"
        lines.insert(1, f"perturbations: {before_after}{kept}")
    for line in lines:
        console.print(line, highlight=False, markup=False)
