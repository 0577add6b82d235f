"""When beatlog may write baselines: the update mode a run asks for, and the CI rule;
and when approved baselines have gone stale: the project's limits on open loop.

Like vcrpy's record modes, the update mode is a str Enum: ``"none"`` (the default)
never writes, ``"new"`` writes the new baseline of each failing DTC to its pending
file for review. Whatever the mode, nothing is written when the ``CI`` environment
variable is set: a CI run judges against the committed baselines, it never makes them.

An approved baseline that leaves the recording runs *open loop* from there: the recorded
world no longer answers to what the behaviors do, so the DTC tests less the longer it
runs so. A project may bound that (``max_open_loop_share``, ``max_open_loop_dtcs`` in
``[tool.beatlog]``): past the bounds the suite is stale and fails, naming the sessions
to re-record first (:func:`stale_suite`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import TYPE_CHECKING, NamedTuple

from beatlog.errors import CiWriteError, OptionError

if TYPE_CHECKING:
    from beatlog.replay.verdict import Divergence

__all__ = [
    "SpecOptions",
    "StaleSuite",
    "UpdateMode",
    "in_ci",
    "open_loop_share",
    "refusal",
    "require_writable",
    "stale_suite",
]


class UpdateMode(StrEnum):
    """What a suite run does with the baselines of its DTCs."""

    NONE = "none"
    """Write nothing: a failing DTC only fails. The safe default, and CI's."""
    NEW = "new"
    """Write the new baseline of each failing DTC to its pending file, for review and
    approval; a passing DTC's stale pending file is removed."""

    @classmethod
    def parse(cls, value: UpdateMode | str) -> UpdateMode:
        """The mode named by ``value``; anything else raises :class:`OptionError` listing
        the modes there are."""
        try:
            return cls(value)
        except ValueError:
            valid = ", ".join(repr(mode.value) for mode in cls)
            raise OptionError(f"unknown update mode {value!r}: choose one of {valid}") from None


def in_ci() -> bool:
    """Whether the ``CI`` environment variable says this is a CI run (baselines stay put)."""
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def require_writable() -> None:
    """Raise :class:`CiWriteError` when ``CI`` is set: baselines are never written there."""
    if in_ci():
        raise CiWriteError


@dataclass(frozen=True)
class SpecOptions:
    """What a suite run asks of each DTC besides its verdict (see
    :func:`beatlog.suite.runner.run_spec`)."""

    update: UpdateMode = UpdateMode.NONE
    audit: bool = False
    timelines: bool = False
    break_at: int | None = None
    """Stop in the debugger just before the behaviors update in this cycle."""
    break_on_divergence: bool = False
    """Replay a failing DTC again, stopping in the debugger at its first divergence."""
    coverage: bool = False
    """Gather the state changes its log recorded, for the suite's coverage, as the
    verdict's replay reads them."""
    verdict_only: bool = False
    """The verdict's replay alone: a failure is neither replayed again to see that it
    repeats nor for its details (what ``beatlog shrink`` asks of each window it tries)."""


def open_loop_share(cycles: int, open_loop: int | None) -> float:
    """The share of a DTC's ``cycles`` that run open loop, from cycle ``open_loop``."""
    if open_loop is None or cycles <= 0:
        return 0.0
    return max(0, cycles - open_loop) / cycles


class StaleSuite(NamedTuple):
    """A suite past its project's open-loop limits."""

    open_loop: int
    """The DTCs that run open loop."""
    over_share: int
    """Those that run open loop for more of their cycles than the project allows."""
    rerecord: tuple[tuple[str, float], ...]
    """The DTCs to re-record first (each with its open-loop share), most open loop first:
    those over the share, then as many more as the number allowed needs."""
    max_share: float | None
    max_dtcs: int | None


def stale_suite(
    shares: Sequence[tuple[str, float]], *, max_share: float | None, max_dtcs: int | None
) -> StaleSuite | None:
    """Whether the DTCs, each named with the share of its cycles run open loop, are past
    the limits: none of them more open loop than ``max_share``, no more than ``max_dtcs``
    open loop at all (None: no limit); None when they are within them."""
    ranked = sorted((dtc for dtc in shares if dtc[1] > 0), key=lambda dtc: -dtc[1])
    over = sum(max_share is not None and share > max_share for _, share in ranked)
    extra = 0 if max_dtcs is None else max(0, len(ranked) - over - max_dtcs)
    if not over and not extra:
        return None
    return StaleSuite(len(ranked), over, tuple(ranked[: over + extra]), max_share, max_dtcs)


def refusal(divergence: Divergence) -> str | None:
    """Why a divergence cannot be re-baselined, if it cannot: a behavior that raised,
    or an invariant that does not hold, is a bug; a log that ended early, perception
    that built nothing or set-up draws made otherwise (a baseline holds none) need
    fixing or a new recording."""
    from beatlog.replay.verdict import DivergenceKind  # noqa: PLC0415 - the CLI starts without it

    kind = divergence.kind
    if kind is DivergenceKind.EXCEPTION:
        return "a behavior raised: an exception is a bug, never a baseline; fix it first"
    if kind is DivergenceKind.INVARIANT:
        return "an invariant does not hold: a violation is a bug, never a baseline; fix it first"
    if kind in (DivergenceKind.LOG_ENDED, DivergenceKind.SETUP):
        return f"a divergence in {kind} cannot be re-baselined: re-record the session"
    if kind is DivergenceKind.PERCEPTION and not divergence.perception:
        return (
            "perception raised or built no robot state: a baseline pins what perception "
            "rebuilds; fix it first"
        )
    return None
