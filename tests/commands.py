"""Running ``beatlog`` commands in process or in a process of their own, and the checks
every command test shares."""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Callable, Mapping, Sequence
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


def assert_one_line_error(run: Run, *fragments: str) -> None:
    assert run.code == 2
    assert run.out == ""
    assert run.err.startswith("beatlog: error: ")
    assert run.err.endswith("\n")
    assert run.err.count("\n") == 1, run.err
    assert "Traceback" not in run.err
    for fragment in fragments:
        assert fragment in run.err


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
