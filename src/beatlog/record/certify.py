"""Replayability certified where a session is recorded: the log just written replays
against a fresh system from the factory that built the recording one.

A behavior that reads the global ``random`` or the wall clock records a session that
no replay reproduces; certifying at the end of the recording catches it on the robot,
not later in CI. A log that does not replay is replayed once more under the leak
watch (:class:`~beatlog.project.leaks.LeakWatch`), which names the calls to blame and
where they are made.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from beatlog.model.setup import SystemFactory
from beatlog.project.leaks import Finding, LeakWatch
from beatlog.replay.judge import replay
from beatlog.replay.verdict import ReplayResult

__all__ = ["Certificate", "certify"]


@dataclass(frozen=True)
class Certificate:
    """Whether a session log replays against a fresh system, and if not, why."""

    result: ReplayResult
    """The replay of the log against a fresh system."""
    findings: tuple[Finding, ...] = ()
    """The wall-clock reads and global random calls the behaviors made in a replay of a
    log that does not replay."""

    @property
    def ok(self) -> bool:
        """Whether the log replays as recorded."""
        return self.result.ok

    def describe(self) -> str:
        """One line: ``certified: ...`` or ``not certified: ...`` with the first cycle
        that replays otherwise and the calls to blame."""
        result = self.result
        divergence = result.divergence
        if divergence is None:
            return f"certified: the log replays against a fresh system ({result.cycles} cycles)"
        culprits = (
            "; ".join(map(str, self.findings))
            if self.findings
            else "no wall-clock read or global random call seen: look for state kept "
            "outside the system (module globals, class attributes) or input not read "
            "from the robot state"
        )
        return (
            f"not certified: a fresh system replays the log otherwise from cycle "
            f"{divergence.cycle} ({divergence.kind.value}: {divergence.message}); {culprits}"
        )


def certify(log: str | Path, system: SystemFactory) -> Certificate:
    """Replay ``log`` against a fresh system from the factory ``system`` (handed the
    recorded set-up draws where it takes ``random``); where it diverges, replay it once
    more against another under a leak watch, to name the calls to blame.

    :raises beatlog.errors.BeatlogError: the log cannot be read or does not fit.
    """
    result = replay(log, system, allow_empty=True, explain=False)
    if result.ok:
        return Certificate(result)
    watch = LeakWatch()
    with watch:
        replay(log, system, allow_empty=True, explain=False)
    return Certificate(result, tuple(watch.findings()))
