"""What every test of the repository shares: the library's, the benchmarks' and the
example robots'."""

from __future__ import annotations

import pytest


@pytest.fixture(autouse=True)
def outside_ci(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every test starts outside CI, wherever the suite runs: ``CI`` withholds baselines,
    so a test that means CI sets it itself."""
    monkeypatch.delenv("CI", raising=False)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The test marked ``first`` runs first. pytest-xdist hands each worker runs of
    consecutive tests and never takes back what it handed out, so the suite's longest
    test (the README's tour, a minute) near the end of the collection kept its worker
    busy long after the other had finished; first, the other tests balance around it."""
    items.sort(key=lambda item: item.get_closest_marker("first") is None)
