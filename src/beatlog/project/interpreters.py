"""The interpreters beatlog starts to run the user's code in (suite workers, audit
replays, a local Dask cluster's processes), and how Ctrl-C meets them. Each is born with
Ctrl-C held back: ours take it once they have said what Ctrl-C does there
(:func:`take_ctrl_c`), so a Ctrl-C pressed while one is still importing neither ends it
with a traceback nor goes unheard; a local cluster's leave it to this process, which
stops them (:func:`ctrl_c_deferred`)."""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
import threading
import warnings
from collections.abc import Iterator, Sequence
from types import FrameType
from typing import Any

__all__ = ["ctrl_c_deferred", "quiet_abandoned_reads", "start_interpreter", "take_ctrl_c"]


@contextlib.contextmanager
def _sigint_blocked() -> Iterator[None]:
    """While the block runs, this thread holds SIGINT back (one that comes for it waits)."""
    held = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)


def start_interpreter(module: str, args: Sequence[str], **popen: Any) -> subprocess.Popen[bytes]:
    """``python -m MODULE ARGS...`` under this Python, with ``popen`` given to
    :class:`subprocess.Popen`, born with SIGINT blocked (a child inherits the blocked
    signals of the thread that starts it). This process still gets a Ctrl-C meanwhile:
    only this thread holds it back, and only until the child is started."""
    with _sigint_blocked():
        return subprocess.Popen([sys.executable, "-m", module, *args], **popen)


def take_ctrl_c() -> None:
    """In an interpreter :func:`start_interpreter` started, once its SIGINT handler is set:
    let Ctrl-C reach it, one pressed while it started included."""
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def quiet_abandoned_reads() -> None:
    """From now on, no warning of a coroutine never awaited: once Ctrl-C or SIGTERM has
    come, what the interruption abandons (an async download's read, scheduled and never
    started) is not the user's. Called by the handler, before the interruption unwinds."""
    warnings.filterwarnings("ignore", "coroutine .* was never awaited", RuntimeWarning)


@contextlib.contextmanager
def ctrl_c_deferred() -> Iterator[None]:
    """While the block runs, the processes it starts (through the threads it starts too)
    are born with Ctrl-C blocked, leaving it to this process; and a Ctrl-C or SIGTERM
    that comes meanwhile stops this process only as the block ends, as it would have then.
    For a start-up that, cut half-way, leaves what cannot be closed (a local Dask
    cluster's). A second one does not wait. Only the main thread handles signals:
    elsewhere the processes are born deaf all the same, and signals come as they come."""
    from multiprocessing import resource_tracker  # noqa: PLC0415 - not in the replay's workers

    resource_tracker.ensure_running()  # its first start unblocks Ctrl-C in its thread
    if threading.current_thread() is not threading.main_thread():
        with _sigint_blocked():
            yield
        return
    came: list[int] = []

    def restore() -> None:
        for signum, handler in previous.items():
            signal.signal(signum, signal.SIG_DFL if handler is None else handler)

    def defer(signum: int, frame: FrameType | None) -> None:
        came.append(signum)
        if len(came) > 1:  # asked again: no more waiting
            restore()
            signal.raise_signal(signum)

    previous = {signum: signal.signal(signum, defer) for signum in (signal.SIGINT, signal.SIGTERM)}
    try:
        with _sigint_blocked():  # one held back comes as the block ends, deferred
            yield
    finally:
        restore()
        if len(came) == 1:
            signal.raise_signal(came[0])
