"""When beatlog may write baselines: the update mode a run asks for, and the CI rule.

Like vcrpy's record modes, the update mode is a str Enum: ``"none"`` (the default)
never writes, ``"new"`` writes the new expectation of each failing DTC to its pending
file for review. Whatever the mode, nothing is written when the ``CI`` environment
variable is set: a CI run judges against the committed baselines, it never makes them.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from enum import StrEnum

from beatlog.errors import CiWriteError, OptionError

__all__ = ["SpecOptions", "UpdateMode", "in_ci", "require_writable"]


class UpdateMode(StrEnum):
    """What a suite run does with the baselines of its DTCs."""

    NONE = "none"
    """Write nothing: a failing DTC only fails. The safe default, and CI's."""
    NEW = "new"
    """Write the new expectation of each failing DTC to its pending file, for review and
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
