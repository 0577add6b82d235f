"""The pytest plugin: DTC specs become test items, and a fixture replays logs in tests.

Registered under the ``pytest11`` entry point, so installing beatlog is enough:
``pytest`` collects every ``*.dtc.toml`` file as one test named after the spec. Set
``beatlog_collect = false`` in the pytest ini options to turn collection off. DTC
items carry the ``dtc`` marker, and ``-k`` matches their names and tags.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from beatlog.errors import SpecError
from beatlog.model.behavior import System
from beatlog.replay.judge import replay
from beatlog.replay.verdict import ReplayResult
from beatlog.report.console import plain_text, render_replay
from beatlog.suite.runner import Verdict, run_spec
from beatlog.suite.spec import SPEC_SUFFIX, DtcSpec, load_spec

__all__ = ["DtcFile", "DtcItem", "beatlog_replay"]


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addini(
        "beatlog_collect",
        type="bool",
        default=True,
        help="collect *.dtc.toml files as beatlog deterministic test cases",
    )


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "dtc: a beatlog deterministic test case (*.dtc.toml)")


def pytest_collect_file(parent: pytest.Collector, file_path: Path) -> pytest.Collector | None:
    if file_path.name.endswith(SPEC_SUFFIX) and parent.config.getini("beatlog_collect"):
        return DtcFile.from_parent(parent, path=file_path)
    return None


class DtcFailedError(AssertionError):
    """A DTC that diverged; carries the text pytest shows."""


class DtcFile(pytest.File):
    """A ``*.dtc.toml`` spec file: one test item."""

    def collect(self) -> Iterator[pytest.Item]:
        try:
            spec = load_spec(self.path)
        except SpecError as exc:
            raise self.CollectError(str(exc)) from None
        yield DtcItem.from_parent(self, name=spec.name, spec=spec)


class DtcItem(pytest.Item):
    """One deterministic test case: replay the spec's log against its system."""

    def __init__(self, *, spec: DtcSpec, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.spec = spec
        self.add_marker("dtc")
        self.extra_keyword_matches.update(spec.tags)

    def runtest(self) -> None:
        outcome = run_spec(self.spec)
        if outcome.verdict is Verdict.ERROR:
            shown = outcome.error_traceback if self.config.get_verbosity() > 0 else None
            raise DtcFailedError(f"{outcome.error}\n{shown}" if shown else outcome.error)
        if outcome.result is not None and not outcome.result.ok:
            raise DtcFailedError(_failure_text(outcome.result))

    def repr_failure(
        self,
        excinfo: pytest.ExceptionInfo[BaseException],
        style: Any = None,
    ) -> str:
        if isinstance(excinfo.value, DtcFailedError):
            return str(excinfo.value)
        return str(super().repr_failure(excinfo, style=style))

    def reportinfo(self) -> tuple[Path, int, str]:
        return self.path, 0, f"dtc: {self.spec.name}"


def _failure_text(result: ReplayResult) -> str:
    return plain_text(render_replay(result))


@pytest.fixture
def beatlog_replay() -> Callable[..., ReplayResult]:
    """Replay a session log in an ordinary test; a divergence fails the test readably.

    ``beatlog_replay(log, system, **options)`` takes the same arguments as
    :func:`beatlog.replay` and returns its result when the replay passes.
    """

    def run(log: str | Path, system: System | str, **options: Any) -> ReplayResult:
        result = replay(log, system, **options)
        if not result.ok:
            pytest.fail(_failure_text(result), pytrace=False)
        return result

    return run
