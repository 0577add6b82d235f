"""The replay debugger: stop in pdb just before the behaviors update in a chosen cycle.

A break (``beatlog replay --break-at CYCLE``, ``replay(..., break_at=)``) hands that
cycle's update to :func:`pause`, with the context already the cycle's: the debugger stops
on the line that calls ``system.update``, so one ``s`` steps into it. The stop honours
``breakpoint()``'s choice of debugger (``PYTHONBREAKPOINT``, ``sys.breakpointhook``,
pytest's ``pdb.set_trace``). Quitting it raises :class:`DebuggerQuit`: the replay stops
as at Ctrl-C, where the ``BdbQuit`` pdb raises would pass for the behaviors failing.
"""

from __future__ import annotations

import os
import pdb
import sys
from bdb import BdbQuit
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any, Literal

from beatlog.log.index import recorded_cycles

if TYPE_CHECKING:
    from collections.abc import Callable

    from beatlog.model.behavior import BehaviorState, System
    from beatlog.model.context import Context
    from beatlog.model.cycle import Update
    from beatlog.model.random import Draw
    from beatlog.replay.verdict import ReplayResult

__all__ = [
    "Debugger",
    "DebuggerQuit",
    "beyond_the_log",
    "break_on_divergence",
    "pause",
    "unreached_break",
]


class DebuggerQuit(KeyboardInterrupt):
    """The debugger was quit at a break: the replay stops, as at Ctrl-C.

    A ``KeyboardInterrupt``, which replay never takes for the behaviors failing."""

    def __init__(self) -> None:
        super().__init__("stopped in the debugger")


class Debugger(pdb.Pdb):
    """pdb that quits with :class:`DebuggerQuit` wherever it is quit: in a behavior or in
    the replay core, the ``BdbQuit`` pdb raises (or the ``Exit`` of pytest's pdb, which
    the pytest plugin builds on this class while break points are on) would be taken for
    the behaviors failing."""

    def trace_dispatch(self, frame: FrameType, event: str, arg: Any) -> Any:
        try:
            return super().trace_dispatch(frame, event, arg)
        except _quits():
            raise DebuggerQuit from None

    def set_stepinstr(self) -> None:
        """Stop on the line after ``set_trace``, the one that updates the behaviors, as
        before Python 3.13, whose ``set_trace`` stops on its own line by this call."""
        self.set_step()


def pause(
    update: Update,
    robot_state: Any,
    context: Context,
    *,
    system: System,
    log: Path,
    recorded_state: Any,
    recorded_changes: list[tuple[str, BehaviorState, BehaviorState]],
    recorded_draws: list[Draw],
) -> None:
    """Stop in the debugger on the line that updates the behaviors, then update them.

    The locals are what is at hand: ``robot_state`` (RS_t as the behaviors get it),
    ``context`` (the cycle's), ``system``, ``recorded_changes`` (BS_t by behavior name),
    ``recorded_draws`` (RN_t), ``recorded_state`` (RS_t as recorded; in sensor-level
    replay the behaviors get it rebuilt from the samples) and ``log``.
    """
    state = (
        "robot_state (RS_t rebuilt from the samples), recorded_state (RS_t as recorded)"
        if recorded_state is not robot_state
        else "robot_state (RS_t)"
    )
    header = (
        f"beatlog: cycle {context.cycle} of {log.name}, t = {context.time:.3f} s "
        f"(HB_t {context.dt_ns / 1e6:.3f} ms), just before the behaviors update\n"
        f"at hand: {state}, recorded_changes (BS_t), recorded_draws (RN_t), context, system\n"
        "`s` steps into system.update, `c` replays on, `q` stops"
    )
    debugger = _chosen_debugger()
    try:
        if debugger == "pdb":
            stop = Debugger()
            stop.message(header)
            stop.set_trace(sys._getframe())
        elif debugger == "set_trace":
            breakpoint(header=header)
        elif debugger == "hook":
            print(header, file=sys.stderr)
            breakpoint()
        update(robot_state, context)  # `s` steps into system.update
    except _quits():
        raise DebuggerQuit from None


def _chosen_debugger() -> Literal["pdb", "set_trace", "hook", "off"]:
    """What ``breakpoint()`` would run here: the standard library's pdb, a
    ``pdb.set_trace`` put in its place (pytest's, which takes a header too), another hook
    (``PYTHONBREAKPOINT``, ``sys.breakpointhook``), or nothing (``PYTHONBREAKPOINT=0``)."""
    if sys.breakpointhook is not sys.__breakpointhook__:
        return "hook"
    chosen = "" if sys.flags.ignore_environment else os.environ.get("PYTHONBREAKPOINT", "")
    if chosen == "0":
        return "off"
    if chosen not in ("", "pdb.set_trace"):
        return "hook"
    return "pdb" if pdb.set_trace.__module__ == pdb.__name__ else "set_trace"


def _quits() -> tuple[type[BaseException], ...]:
    """What quitting another debugger raises: ``BdbQuit`` (those built on bdb) and, under
    pytest, whose pdb quits with ``pytest.exit``, its ``Exit``."""
    pytest = sys.modules.get("pytest")
    return (BdbQuit,) if pytest is None else (BdbQuit, pytest.exit.Exception)


def beyond_the_log(break_at: int, log: Path) -> str | None:
    """Why a break at cycle ``break_at`` cannot be reached in ``log``, where its end record
    counts too few cycles (read cheaply: :func:`~beatlog.log.index.recorded_cycles`)."""
    cycles = recorded_cycles(log)
    if cycles is None or break_at < cycles:
        return None
    return f"{log} has only {_cycles(cycles)}; no break would be reached"


def unreached_break(break_at: int | None, result: ReplayResult) -> tuple[str, ...]:
    """The note for a replay whose break lay past the end of its log (which replay reads
    whole), or none."""
    status = result.status
    if break_at is None or status is None or break_at < status.cycles:
        return ()
    return (
        f"the break at cycle {break_at} was never reached: the log has only "
        f"{_cycles(status.cycles)}",
    )


def break_on_divergence(
    result: ReplayResult, replay_to: Callable[[int], object]
) -> tuple[str, ...]:
    """Replay again with ``replay_to(cycle)``, stopping at the first divergence of
    ``result``, when it has one; a divergence at the log's end (it was cut off) has no
    cycle to stop in, and gets the note :func:`unreached_break` gives instead."""
    divergence = result.divergence
    if divergence is None:
        return ()
    missed = unreached_break(divergence.cycle, result)
    if not missed:
        replay_to(divergence.cycle)
    return missed


def _cycles(count: int) -> str:
    return f"{count} cycle{'' if count == 1 else 's'}"
