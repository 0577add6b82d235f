"""Fixtures for the command tests: commands run in process on a wide, plain console."""

from __future__ import annotations

import pytest


@pytest.fixture
def wide_plain_console(monkeypatch: pytest.MonkeyPatch) -> None:
    """Rich wraps at 80 columns when not on a terminal; long tmp paths would be split."""
    monkeypatch.setenv("COLUMNS", "200")
    monkeypatch.delenv("FORCE_COLOR", raising=False)


@pytest.fixture
def outside_ci(monkeypatch: pytest.MonkeyPatch) -> None:
    """Not on CI, where ``beatlog test`` refuses to write baselines."""
    monkeypatch.delenv("CI", raising=False)
