"""Running ``beatlog`` commands in process, stopped by a signal or at a terminal, and the
checks every command test shares."""

from __future__ import annotations

import contextlib
import inspect
import os
import pty
import re
import select
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import NamedTuple

import pytest

ROOT = Path(__file__).parents[1]
_ESCAPE = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


class Run(NamedTuple):
    """What one command did: its exit code and what it printed."""

    code: int
    out: str
    err: str


Beatlog = Callable[..., Run]
"""Runs one ``beatlog`` command in process (see the ``beatlog`` fixture)."""


def assert_error(run: Run, message: str) -> None:
    """The command refused its input in one line: exit 2, nothing on stdout, and
    ``beatlog: error: MESSAGE`` on stderr."""
    expected = (2, "", f"beatlog: error: {message}\n")
    assert (run.code, run.out, run.err) == expected, f"{run!r} is not {expected!r}"


def assert_error_matching(run: Run, pattern: str) -> None:
    """As ``assert_error``, for a message of which a part varies from run to run (a port, a
    folder, an operating system's words): the whole message matches the regular expression
    ``pattern``, whose fixed parts the test escapes."""
    assert (run.code, run.out) == (2, ""), run
    assert re.fullmatch(f"beatlog: error: {pattern}\n", run.err), run.err


def cannot_import(module: str) -> str:
    """The pattern of what a reference to ``module``, which does not exist, is told, whole;
    the folders it says it looked in are those of the process, which vary."""
    return (
        re.escape(f"cannot import {module}: No module named {module!r} (looked in ")
        + r"[^ ,]+(, [^ ,]+)*"
        + re.escape(
            " and the installed packages; a reference imports from the working directory, a "
            "spec's folder and its project root, the nearest folder above it with a "
            "pyproject.toml)"
        )
    )


def failing_line(factory: Callable[[], object]) -> str:
    """Where ``factory``, which raises on its last line, failed, as beatlog names it."""
    lines, first = inspect.getsourcelines(factory)
    return f"line {first + len(lines) - 1} of {inspect.getsourcefile(factory)}"


def replay_line(verdict: str, log: str | Path, checked: str) -> str:
    """The pattern of the line ``beatlog replay`` sums a complete log up in, e.g. ``PASS
    LOG  300 cycles, ...; 9.0 s robot time in 0.004 s (2,250× real time); log complete``:
    how fast it replayed varies, from run to run and machine to machine."""
    return (
        re.escape(f"{verdict} {log}  {checked} in ")
        + r"(under 1 ms|\d+\.\d{3} s( \([\d,.]+× real time\))?)"
        + re.escape("; log complete")
    )


def closing_counts(out: str) -> str:
    """The counts of ``beatlog test``'s closing line (``2 passed, 1 failed, 1 not run``),
    without the wall time and the cycles that follow them."""
    return out.rstrip("\n").splitlines()[-1].partition(" in ")[0]


def plain(text: str) -> str:
    """What a terminal shows of ``text``: without its escape sequences (colours, cursor
    moves)."""
    return _ESCAPE.sub("", text)


def hide_matplotlib(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make ``import matplotlib`` fail as it does where the plot extra is not installed."""
    for name in [name for name in sys.modules if name.startswith("matplotlib")]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    for name in ("beatlog.report.chart", "beatlog.report.html"):
        monkeypatch.delitem(sys.modules, name, raising=False)


def beatlog_process(args: Sequence[str | Path], *, env: Mapping[str, str]) -> Run:
    """Run ``beatlog ARGS`` in a process of its own with ``env``; a command that hangs
    fails the test."""
    done = subprocess.run(
        [sys.executable, "-m", "beatlog.cli.main", *(str(arg) for arg in args)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    return Run(done.returncode, done.stdout, done.stderr)


def wait_until(condition: Callable[[], bool], timeout_s: float) -> bool:
    """Whether ``condition()`` came to hold within ``timeout_s`` seconds."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def live_members(group: int) -> list[int]:
    """The processes of a process group that still run (zombies left out)."""
    members = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rpartition(")")[2].split()
        except OSError:  # the process ended while we looked
            continue
        if int(fields[2]) == group and fields[0] != "Z":
            members.append(int(stat.parent.name))
    return members


AS_AT_A_TERMINAL = (
    "import runpy, signal, sys\n"
    "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
    "sys.argv[0] = 'beatlog'\n"
    "runpy.run_module('beatlog.cli.main', run_name='__main__', alter_sys=True)\n"
)
"""``python -m beatlog.cli.main`` with Ctrl-C turned into ``KeyboardInterrupt``, as in a
command started at a terminal, even where the tests run in the background (whose
commands inherit SIGINT ignored, and would ignore the Ctrl-C a test presses)."""


def signalled(
    args: Sequence[str | Path],
    ready: Callable[[], bool],
    signum: int,
    *,
    env: Mapping[str, str],
    group: bool = False,
) -> Run:
    """Run ``beatlog ARGS`` in a process group of its own with ``env``, send it
    ``signum`` once ``ready()`` holds (to the whole group with ``group``, as a terminal
    sends Ctrl-C), and collect how it ended; a command that hangs, or leaves processes
    of its group running, fails the test."""
    process = subprocess.Popen(
        [sys.executable, "-c", AS_AT_A_TERMINAL, *(str(arg) for arg in args)],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        started = wait_until(lambda: ready() or process.poll() is not None, 120)
        assert started, "beatlog never got to work"
        assert process.poll() is None, process.communicate()
        if group:
            os.killpg(process.pid, signum)
        else:
            process.send_signal(signum)
        out, err = process.communicate(timeout=30)  # a busy machine unwinds slowly
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.communicate()
    assert wait_until(lambda: not live_members(process.pid), 10), "children outlived it"
    return Run(process.returncode, out, err)


def read_until(terminal: int, text: str | None, *, seconds: float = 20.0) -> str:
    """What the program wrote to the terminal up to ``text`` (or its end, or the time);
    with no ``text``, up to its end."""
    seen = b""
    deadline = time.monotonic() + seconds
    while (text is None or text.encode() not in seen) and time.monotonic() < deadline:
        ready, _, _ = select.select([terminal], [], [], 0.5)
        if ready:
            try:
                chunk = os.read(terminal, 4096)
            except OSError:  # the program closed the terminal: it has ended
                break
            if not chunk:
                break
            seen += chunk
    return seen.decode(errors="replace")


class Terminal:
    """A program at a terminal of its own, driven as a person at the keyboard drives it."""

    def __init__(self, terminal: int, program: subprocess.Popen[bytes]) -> None:
        self.terminal = terminal
        self.program = program

    def until(self, text: str) -> str:
        """What the program showed up to ``text``, as plain text with ``\\n`` line ends;
        the test fails if ``text`` never comes."""
        seen = plain(read_until(self.terminal, text)).replace("\r\n", "\n")
        assert text in seen, seen
        return seen

    def type(self, line: str, *, until: str) -> str:
        """Type ``line`` and Enter; what the program showed then (the line echoed first)
        up to ``until``."""
        os.write(self.terminal, f"{line}\n".encode())
        return self.until(until)

    def end(self, line: str) -> tuple[int, str]:
        """Type ``line`` and Enter; the exit code, and what the program showed until it
        ended (a program still running 30 s later fails the test)."""
        os.write(self.terminal, f"{line}\n".encode())
        seen = plain(read_until(self.terminal, None, seconds=30)).replace("\r\n", "\n")
        return self.program.wait(timeout=30), seen


@contextlib.contextmanager
def at_a_terminal(args: Sequence[str | Path], *, env: Mapping[str, str]) -> Iterator[Terminal]:
    """Run ``python ARGS`` from the repository's root with a pseudo-terminal as its
    stdin, stdout and stderr; a program left running by the block is killed."""
    terminal, program_side = pty.openpty()
    program = subprocess.Popen(
        [sys.executable, *(str(arg) for arg in args)],
        cwd=ROOT,
        env={**env, "TERM": "dumb"},  # no terminal tricks from readline
        stdin=program_side,
        stdout=program_side,
        stderr=program_side,
    )
    os.close(program_side)
    try:
        yield Terminal(terminal, program)
    finally:
        if program.poll() is None:
            program.kill()
        program.wait()
        os.close(terminal)
