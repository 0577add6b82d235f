"""DTC specs as pytest items: a ``*.dtc.toml`` file is one item, judged in its setup."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from beatlog.errors import BeatlogError, SpecError
from beatlog.suite.spec import DtcSpec, load_spec

if TYPE_CHECKING:
    from beatlog.pytest_plugin.run import BeatlogRun
    from beatlog.replay.verdict import ReplayResult
    from beatlog.suite.runner import SpecOutcome

__all__ = [
    "OPEN_LOOP",
    "RUN",
    "SPEC",
    "UPDATE",
    "VERDICT",
    "DtcFailedError",
    "DtcFile",
    "DtcItem",
    "failure_text",
    "quitting_as_pytest",
]

VERDICT, SPEC, UPDATE = "beatlog_verdict", "beatlog_spec", "beatlog_update"
OPEN_LOOP = "beatlog_open_loop"
"""Names of the user properties a DTC's report carries to the summary (across xdist)."""

RUN: pytest.StashKey[BeatlogRun] = pytest.StashKey()
"""Where a pytest run keeps its :class:`~beatlog.pytest_plugin.run.BeatlogRun`."""


class DtcFailedError(AssertionError):
    """A DTC that diverged; carries the text pytest shows."""


class DtcFile(pytest.File):
    """A ``*.dtc.toml`` spec file: one test item."""

    def collect(self) -> Iterator[pytest.Item]:
        try:
            spec = load_spec(self.path, rootdir=self.config.rootpath)
        except SpecError as exc:
            raise self.CollectError(str(exc)) from None
        yield DtcItem.from_parent(self, name=spec.name, spec=spec)


class DtcItem(pytest.Item):
    """One deterministic test case: replay the spec's log against its system."""

    def __init__(self, *, spec: DtcSpec, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.spec = spec
        self.outcome: SpecOutcome | None = None
        self.add_marker("dtc")
        self.extra_keyword_matches.update(spec.tags)

    def setup(self) -> None:
        """Judge the DTC: one that cannot run (its log or system is bad input) is an error
        of this phase, so pytest reports it as an ERROR, as ``beatlog test`` does."""
        from beatlog.report.baselines import render_updates  # noqa: PLC0415 - see the imports
        from beatlog.suite.maintenance import update_baselines  # noqa: PLC0415
        from beatlog.suite.runner import Verdict, run_spec  # noqa: PLC0415

        run = self.config.stash[RUN]
        with quitting_as_pytest():
            outcome = self.outcome = run_spec(self.spec, run.options)
        if outcome.recorded is not None:
            run.recorded[self.spec.path] = outcome.recorded
        self.user_properties.append((VERDICT, outcome.verdict.value))
        self.user_properties.append((SPEC, str(self.spec.path)))
        if outcome.open_loop is not None:
            self.user_properties.append((OPEN_LOOP, outcome.open_loop[0]))
        if outcome.result is not None:  # what it checked, as beatlog test's JUnit has it
            self.user_properties.extend(
                (f"beatlog_{name}", count) for name, count in outcome.result.counts.items()
            )
        try:
            updates = update_baselines([outcome], run.update)
        except BeatlogError as exc:  # a full disk: one line, as beatlog test says it
            pytest.fail(str(exc), pytrace=False)
        for line in render_updates(updates):
            self.user_properties.append((UPDATE, line.plain))
        if outcome.verdict is Verdict.ERROR:
            shown = outcome.error_traceback if self.config.get_verbosity() > 0 else None
            pytest.fail(f"{outcome.error}\n{shown}" if shown else str(outcome.error), pytrace=False)

    def runtest(self) -> None:
        """Fail with the DTC's first divergence, and with what its audit found."""
        from beatlog.report.audit import render_audit  # noqa: PLC0415 - see the imports
        from beatlog.report.console import plain_text  # noqa: PLC0415

        outcome = self.outcome
        assert outcome is not None, "setup judges the DTC"
        failures = []
        if outcome.result is not None and not outcome.result.ok:
            failures.append(failure_text(outcome.result))
        if outcome.audit_findings:
            failures.append(plain_text(render_audit([outcome])))
        if failures:
            raise DtcFailedError("\n".join(failures))

    def repr_failure(
        self,
        excinfo: pytest.ExceptionInfo[BaseException],
        style: Any = None,
    ) -> str:
        if isinstance(excinfo.value, DtcFailedError):
            return str(excinfo.value)
        return str(super().repr_failure(excinfo, style=style))

    def reportinfo(self) -> tuple[Path, int, str]:
        return self.path, 0, f"dtc: {self.spec.label}"


@contextmanager
def quitting_as_pytest() -> Iterator[None]:
    """Quitting the debugger at a break ends the session as quitting pytest's pdb does
    (``pytest.exit``), not as a Ctrl-C."""
    try:
        yield
    except KeyboardInterrupt as stop:
        from beatlog.replay.debugger import DebuggerQuit  # noqa: PLC0415 - see the imports

        if isinstance(stop, DebuggerQuit):
            pytest.exit("Quitting debugger")
        raise


def failure_text(result: ReplayResult) -> str:
    from beatlog.report.console import plain_text, render_replay  # noqa: PLC0415

    return plain_text(render_replay(result))
