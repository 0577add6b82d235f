"""Running ``beatlog`` commands in process, and the checks every command test shares."""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import NamedTuple

import pytest


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


def hide_matplotlib(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make ``import matplotlib`` fail as it does where the plot extra is not installed."""
    for name in [name for name in sys.modules if name.startswith("matplotlib")]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    for name in ("beatlog.report.chart", "beatlog.report.html"):
        monkeypatch.delitem(sys.modules, name, raising=False)
