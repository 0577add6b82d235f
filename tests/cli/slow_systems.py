"""Probe systems that replay slowly, so a test can press Ctrl-C while beatlog works.

Each process that steps one creates a file named after its pid in the folder that
``$BEATLOG_TEST_MARKERS`` names, so the test knows when to press.
"""

from __future__ import annotations

import asyncio
import os
import time
from pathlib import Path

from beatlog.model.behavior import PriorityArbiter
from beatlog.model.context import Context
from tests.conftest import Dice, Near, Probe

MARKERS = "BEATLOG_TEST_MARKERS"
CYCLE_S = 0.1
"""What each cycle sleeps: a 300-cycle probe log replays in 30 s."""


class SlowArbiter(PriorityArbiter[Probe]):
    """The probe system, sleeping each cycle (only in audit replays, if asked)."""

    def __init__(self, *, only_in_audit: bool = False) -> None:
        super().__init__([Near(), Dice()], robot_state=Probe)
        self.slow = not only_in_audit or "PYTHONHASHSEED" in os.environ
        self.marked = False

    def update(self, state: Probe, context: Context) -> None:
        if self.slow:
            if not self.marked:
                (Path(os.environ[MARKERS]) / str(os.getpid())).touch()
                self.marked = True
            time.sleep(CYCLE_S)
        super().update(state, context)


def slow_system() -> SlowArbiter:
    return SlowArbiter()


def slow_in_audit_system() -> SlowArbiter:
    """Replays at full speed, but slowly in the audit's fresh interpreters."""
    return SlowArbiter(only_in_audit=True)


def abandoning_system() -> SlowArbiter:
    """Waits for Ctrl-C holding a coroutine it never awaits, and drops it as the
    interruption unwinds, as a download that Ctrl-C stops drops fsspec's read."""
    abandoned = asyncio.sleep(0)
    try:
        (Path(os.environ[MARKERS]) / str(os.getpid())).touch()
        time.sleep(60)
    finally:
        del abandoned
    return SlowArbiter()
