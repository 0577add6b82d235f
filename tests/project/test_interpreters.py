"""The interpreters beatlog starts for the user's code: a Ctrl-C pressed while one starts
waits until it has said what Ctrl-C does there, and this process keeps getting Ctrl-C."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

from beatlog.project.interpreters import start_interpreter, take_ctrl_c

STARTING = """\
import signal, sys, time
from beatlog.project.interpreters import take_ctrl_c
print("started", flush=True)
sys.stdin.readline()  # Ctrl-C is pressed meanwhile, before a handler is set
signal.signal(signal.SIGINT, lambda signum, frame: sys.exit(3))
take_ctrl_c()
time.sleep(30)
sys.exit(4)
"""


def test_a_ctrl_c_pressed_while_an_interpreter_starts_waits_for_its_handler(
    tmp_path: Path,
) -> None:
    (tmp_path / "starting.py").write_text(STARTING)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path])}
    child = start_interpreter(
        "starting",
        [],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    assert child.stdout is not None
    assert child.stdout.readline() == b"started\n"

    child.send_signal(signal.SIGINT)
    _, err = child.communicate(b"\n", timeout=30)

    assert (child.returncode, err) == (3, b"")


def test_starting_an_interpreter_leaves_ctrl_c_to_this_thread() -> None:
    child = start_interpreter("json.tool", ["--help"], stdout=subprocess.DEVNULL)
    child.wait(30)

    assert signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, [])


def test_taking_ctrl_c_unblocks_it_in_this_thread() -> None:
    held = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        take_ctrl_c()
        assert signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, [])
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)
