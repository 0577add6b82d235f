"""The interpreters beatlog starts to run the user's code in (suite workers, audit
replays), and how Ctrl-C meets them. Each is born with Ctrl-C held back and takes it only
once it has said what Ctrl-C does there (:func:`take_ctrl_c`): a Ctrl-C pressed while
one is still importing neither ends it with a traceback nor goes unheard; it waits."""

from __future__ import annotations

import signal
import subprocess
import sys
from collections.abc import Sequence
from typing import Any

__all__ = ["start_interpreter", "take_ctrl_c"]


def start_interpreter(module: str, args: Sequence[str], **popen: Any) -> subprocess.Popen[bytes]:
    """``python -m MODULE ARGS...`` under this Python, with ``popen`` given to
    :class:`subprocess.Popen`, born with SIGINT blocked (a child inherits the blocked
    signals of the thread that starts it). This process still gets a Ctrl-C meanwhile:
    only this thread holds it back, and only until the child is started."""
    held = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        return subprocess.Popen([sys.executable, "-m", module, *args], **popen)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)


def take_ctrl_c() -> None:
    """In an interpreter :func:`start_interpreter` started, once its SIGINT handler is set:
    let Ctrl-C reach it, one pressed while it started included."""
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
