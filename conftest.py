"""What every test of the repository shares: the library's, the benchmarks' and the
example robots'."""

from __future__ import annotations

import pytest


@pytest.fixture(autouse=True)
def outside_ci(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every test starts outside CI, wherever the suite runs: ``CI`` withholds baselines,
    so a test that means CI sets it itself."""
    monkeypatch.delenv("CI", raising=False)
