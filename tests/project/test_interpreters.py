"""The interpreters beatlog starts for the user's code: a Ctrl-C pressed while one starts
waits until it has said what Ctrl-C does there, and this process keeps getting Ctrl-C; a
start-up that must not be cut half-way takes a Ctrl-C as it ends, a second at once."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from beatlog.project.interpreters import ctrl_c_deferred, start_interpreter, take_ctrl_c

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

SPAWNING = """\
import multiprocessing, signal
from beatlog.project.interpreters import ctrl_c_deferred

def report(queue):
    queue.put(signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, []))

if __name__ == "__main__":
    context = multiprocessing.get_context("spawn")
    with ctrl_c_deferred():
        queue = context.Queue()  # starts multiprocessing's resource tracker
        child = context.Process(target=report, args=(queue,))
        child.start()
    print(queue.get(timeout=30))
    child.join()
"""


@pytest.fixture
def ctrl_c_raises() -> Iterator[None]:
    """Ctrl-C raises ``KeyboardInterrupt`` here, as at a terminal, for the test."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


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


def pressed_during_start_up(times: int) -> list[str]:
    """Press Ctrl-C ``times`` during a deferred start-up, taken as by another thread of
    this process: what happened, in order."""
    happened = []
    try:
        with ctrl_c_deferred():
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
            for _ in range(times):
                signal.raise_signal(signal.SIGINT)
            happened.append("ended")
    except KeyboardInterrupt:
        happened.append("interrupted")
    return happened


@pytest.mark.usefixtures("ctrl_c_raises")
def test_a_ctrl_c_during_a_deferred_start_up_comes_as_it_ends() -> None:
    assert pressed_during_start_up(1) == ["ended", "interrupted"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


@pytest.mark.usefixtures("ctrl_c_raises")
def test_a_second_ctrl_c_during_a_deferred_start_up_comes_at_once() -> None:
    assert pressed_during_start_up(2) == ["interrupted"]


def test_a_deferred_start_up_leaves_ctrl_c_to_this_process(tmp_path: Path) -> None:
    (tmp_path / "spawning.py").write_text(SPAWNING)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}

    spawned = subprocess.run(
        [sys.executable, tmp_path / "spawning.py"],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
        check=True,
    )

    assert spawned.stdout == "True\n"
    assert signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, [])
