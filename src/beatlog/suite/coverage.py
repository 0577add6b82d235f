"""A suite's transition coverage, from its specs: what each DTC's recording exercises."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from beatlog.analysis.coverage import SuiteCoverage, cover
from beatlog.errors import BeatlogError, OptionError
from beatlog.model.behavior import System
from beatlog.replay.judge import recorded_system
from beatlog.suite.spec import DtcSpec
from beatlog.usercode import load_system

__all__ = ["select_exercising", "suite_coverage"]


def suite_coverage(specs: Sequence[DtcSpec]) -> SuiteCoverage:
    """The coverage of ``specs``: the state changes their logs recorded, with each
    behavior's first and declared states from a fresh system of each spec.

    :raises beatlog.errors.LogError: a spec's log cannot be read.
    :raises beatlog.errors.RemoteLogError: a log behind a URL cannot be copied.
    """
    return cover(_dtcs(specs))


def _dtcs(specs: Sequence[DtcSpec], *, systems: bool = True) -> Iterator[tuple[str, Path, Any]]:
    """Each spec's name, its log as a file here (a log behind a URL copied for as long as
    it is read), and a fresh system when ``systems`` (None where none can be built)."""
    for spec in specs:
        with spec.readable_log() as log:
            system: System | None = None
            if systems:
                try:
                    system = load_system(spec.system or recorded_system(log))
                except BeatlogError:  # the verdict reports it; coverage counts the log
                    system = None
            yield spec.name, log, system


def select_exercising(specs: Sequence[DtcSpec], behavior: str) -> list[DtcSpec]:
    """The specs whose recordings change ``behavior``'s state (read from the logs alone:
    no system is built).

    :raises beatlog.errors.OptionError: none does; the message names the behaviors
        whose states they change.
    """
    coverage = cover(_dtcs(specs, systems=False))
    names = set(coverage.exercising(behavior))
    if not names:
        changed = [name for name, seen in coverage.behaviors.items() if seen.transitions]
        raise OptionError(
            f"no DTC changes the state of behavior {behavior!r}; they change "
            + (", ".join(changed) or "none")
        )
    return [spec for spec in specs if spec.name in names]
