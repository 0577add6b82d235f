"""Fixtures for the command tests: commands run in process on a wide, plain console."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.cli.main import main
from tests.commands import Beatlog, Run


@pytest.fixture
def wide_plain_console(monkeypatch: pytest.MonkeyPatch) -> None:
    """Rich wraps at 80 columns when not on a terminal; long tmp paths would be split."""
    monkeypatch.setenv("COLUMNS", "200")
    monkeypatch.delenv("FORCE_COLOR", raising=False)


@pytest.fixture
def outside_ci(monkeypatch: pytest.MonkeyPatch) -> None:
    """Not on CI, where ``beatlog test`` refuses to write baselines."""
    monkeypatch.delenv("CI", raising=False)


@pytest.fixture
def beatlog(capsys: pytest.CaptureFixture[str]) -> Beatlog:
    """Any ``beatlog`` command, in process; ``test`` with one worker (a pool costs ~0.5 s)."""

    def run(*args: str | Path) -> Run:
        argv = [str(arg) for arg in args]
        if argv[:1] == ["test"]:
            argv[1:1] = ["-j", "1"]
        code = main(argv)
        captured = capsys.readouterr()
        return Run(code, captured.out, captured.err)

    return run
