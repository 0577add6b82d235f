"""The verdict of a replay: pass, or the first divergence with everything needed to read it."""

from __future__ import annotations

import shlex
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import Any, NamedTuple

from beatlog.log.reader import LogStatus
from beatlog.model.cycle import RandomDraw, StateChange

__all__ = [
    "Checked",
    "ContextRow",
    "Divergence",
    "DivergenceKind",
    "FieldDifference",
    "RandomDraw",
    "ReplayResult",
    "StateChange",
    "reproduce_command",
]


def reproduce_command(*argv: str | Path) -> str:
    """The ``beatlog`` command line with these arguments, quoted for a POSIX shell.

    The one builder of the ``reproduce:`` commands that reports print.
    """
    return shlex.join(["beatlog", *map(str, argv)])


class DivergenceKind(StrEnum):
    """How a replayed cycle differed from the recording."""

    STATE_CHANGES = "state changes"
    """The behaviors changed state differently (BS'_t != BS_t)."""
    OUTPUTS = "outputs"
    """The behaviors reported different outputs, e.g. motor commands."""
    RANDOM_OVERDRAWN = "extra random draw"
    """The behaviors drew more random numbers than were recorded."""
    RANDOM_UNDERDRAWN = "missing random draw"
    """The behaviors drew fewer random numbers than were recorded."""
    RANDOM_MISMATCH = "random mismatch"
    """The behaviors drew a different kind or shape of random number."""
    SETUP = "set-up draws"
    """The system's factory drew other random numbers while it built the system than
    were recorded at set-up (before cycle 0)."""
    EXCEPTION = "exception"
    """Behavior code raised an exception."""
    PERCEPTION = "perception"
    """The robot state rebuilt from the logged samples differs from the recorded RS_t
    (sensor-level replay), or perception raised."""
    LOG_ENDED = "log ended"
    """The log ends early: it was truncated before the recording closed it."""
    INVARIANT = "invariant"
    """An invariant did not hold in a replayed cycle, or its own code raised."""


class FieldDifference(NamedTuple):
    """A robot-state field that perception rebuilt differently than it was recorded."""

    field: str
    recorded: Any
    rebuilt: Any

    def __str__(self) -> str:
        return f"{self.field}: recorded {self.recorded!r}, rebuilt {self.rebuilt!r}"


class ContextRow(NamedTuple):
    """One cycle around a divergence: what was recorded and what replay did."""

    cycle: int
    time_ns: int
    expected: tuple[StateChange, ...]
    actual: tuple[StateChange, ...]


@dataclass(frozen=True)
class Divergence:
    """The first cycle where replay differed from the recording, and why."""

    kind: DivergenceKind
    cycle: int
    time_ns: int
    message: str
    behavior: str | None = None
    expected: tuple[StateChange, ...] = ()
    actual: tuple[StateChange, ...] = ()
    expected_outputs: dict[str, Any] = field(default_factory=dict)
    actual_outputs: dict[str, Any] = field(default_factory=dict)
    robot_state: dict[str, Any] = field(default_factory=dict)
    random_recorded: tuple[RandomDraw, ...] = ()
    random_drawn: tuple[RandomDraw, ...] = ()
    traceback: str | None = None
    context: tuple[ContextRow, ...] = ()
    """The cycles before and after the divergence that changed any behavior state."""
    fields_read: tuple[str, ...] = ()
    """The robot-state fields the behaviors read in the diverging cycle (empty: unknown)."""
    proposed_renames: dict[str, str] = field(default_factory=dict)
    """Old → new behavior names, when the whole trace differs only by this renaming."""
    perception: tuple[FieldDifference, ...] = ()
    """In a perception divergence: the fields rebuilt differently from the samples."""
    samples: tuple[tuple[str, Any], ...] = ()
    """In a perception divergence: the cycle's samples (sensor, value), in order."""
    invariant: str | None = None
    """In an invariant divergence: the invariant that did not hold (or raised)."""
    states: dict[str, Any] = field(default_factory=dict)
    """In an invariant divergence: every behavior's state after the cycle's update."""

    @property
    def time_s(self) -> float:
        """Robot time of the diverging cycle in seconds."""
        return self.time_ns / 1e9

    @property
    def perception_sides(self) -> tuple[list[str], list[str]]:
        """The fields perception rebuilt otherwise, as ``field = value``: as recorded,
        and as rebuilt."""
        differences = self.perception
        return (
            [f"{d.field} = {d.recorded!r}" for d in differences],
            [f"{d.field} = {d.rebuilt!r}" for d in differences],
        )

    @property
    def output_sides(self) -> tuple[list[str], list[str]]:
        """The outputs as ``name = value``: expected, and actual."""
        return (
            [f"{name} = {value!r}" for name, value in self.expected_outputs.items()],
            [f"{name} = {value!r}" for name, value in self.actual_outputs.items()],
        )

    @property
    def samples_text(self) -> str:
        """The cycle's samples on one line: ``range [1.0, 1]; imu 0.0``."""
        return "; ".join(f"{sensor} {value!r}" for sensor, value in self.samples)


@dataclass(frozen=True)
class Checked:
    """What a replay compared with the recording (or the approved baseline) and found
    the same, in the cycles that agreed: what a PASS stands on."""

    state_changes: int = 0
    """Behavior state changes."""
    outputs: int = 0
    """Output values (one per name reported in a cycle)."""
    draws: int = 0
    """Random numbers drawn, each checked for what was asked (those drawn at set-up
    included)."""
    samples: int = 0
    """Sensor samples that perception rebuilt a recorded robot state from (sensor-level
    replay)."""

    @property
    def anything(self) -> bool:
        """Whether any state change, output, draw or sample was compared."""
        return bool(self.state_changes or self.outputs or self.draws or self.samples)


@dataclass(frozen=True)
class ReplayResult:
    """What replaying one session log against a system gave."""

    log: Path
    ok: bool
    cycles: int
    """Cycles replayed."""
    checked: Checked
    """What was compared and found the same; a replay that checked nothing (no cycle, or
    no state change, output, draw or sample) is refused unless it was allowed to be
    empty (see :func:`beatlog.replay`)."""
    robot_time_ns: int
    wall_time_s: float
    """Wall time from opening the log (its header read and checked against the system)
    to the last cycle judged."""
    status: LogStatus | None
    """How the log ended; None when replay stopped at a divergence before reading it all."""
    divergence: Divergence | None
    """The first divergence, or None when the replay passed."""
    divergent_cycles: int
    """Cycles that diverged; more than one only when replay was told to keep going."""
    reproduce: str
    """A command that reproduces this verdict: ``beatlog replay`` with the options replay
    was given or, for a DTC run from its spec, ``beatlog test SPEC`` (which brings the
    spec's allowances and approved baseline along)."""
    notes: tuple[str, ...] = ()
    """What a reader should know about how the log was replayed, e.g. that a perception
    step was given but not run, because the log holds no samples."""
    url: str | None = None
    """The URL of the log, when it lay behind one: ``log`` is then the copy replayed,
    which is gone."""

    @property
    def counts(self) -> dict[str, int]:
        """What the replay checked, by name: ``cycles``, ``state_changes``, ``outputs``,
        ``draws`` and ``samples``."""
        checked = self.checked
        return {
            "cycles": self.cycles,
            "state_changes": checked.state_changes,
            "outputs": checked.outputs,
            "draws": checked.draws,
            "samples": checked.samples,
        }

    @property
    def log_name(self) -> str:
        """The log as messages name it: its URL, or its path."""
        return str(self.log) if self.url is None else self.url

    @property
    def robot_time_s(self) -> float:
        """Robot time replayed in seconds."""
        return self.robot_time_ns / 1e9

    @property
    def speedup(self) -> float:
        """Robot time replayed per second of wall time (× real time), opening the log
        included."""
        return self.robot_time_s / self.wall_time_s if self.wall_time_s > 0 else float("inf")
