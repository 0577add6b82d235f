"""The pytest plugin: DTC specs become test items, and a fixture replays logs in tests.

Registered under the ``pytest11`` entry point, so installing beatlog is enough: every
``*.dtc.toml`` is one test named after the spec (``beatlog_collect = false`` in the ini
options turns that off), marked ``dtc`` and matched by ``-k`` on its name and tags, and
each variant it declares is a test of its own (``dock[variant-3]``). A DTC is judged in
its item's setup: one that cannot run (``beatlog test``'s error) is an ERROR, one that
diverges fails. The options of the ``beatlog`` group do what ``beatlog test``'s do (see
:func:`pytest_addoption`); the break points stop as ``beatlog replay``'s do
(:mod:`beatlog.replay.debugger`), with pytest's pdb built on its debugger so that
quitting ends the session, and need the DTCs run in this process (no ``-n``).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from beatlog.baseline.policy import SpecOptions, UpdateMode
from beatlog.errors import BeatlogError
from beatlog.pytest_plugin.run import (
    RUN,
    BeatlogRun,
    DtcFile,
    DtcItem,
    failure_text,
    quitting_as_pytest,
)
from beatlog.suite.spec import SPEC_SUFFIX

if TYPE_CHECKING:
    from beatlog.model.behavior import System
    from beatlog.replay.verdict import ReplayResult

# The engines and reports are imported where a DTC runs or the summary is written: every
# pytest process loads this plugin (each xdist worker too), most of them to run no DTC.

__all__ = ["DtcFile", "DtcItem", "beatlog_replay"]


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("beatlog", "beatlog deterministic test cases (*.dtc.toml)")
    group.addoption(
        "--beatlog-update",
        action="store_const",
        const=UpdateMode.NEW.value,
        default=UpdateMode.NONE.value,
        dest="beatlog_update",
        help="write what each failing DTC now does as its pending baseline, for "
        "review (beatlog review, beatlog approve); never when CI is set",
    )
    group.addoption(
        "--beatlog-audit",
        action="store_true",
        dest="beatlog_audit",
        help="also replay each DTC twice with different hash seeds, watching for wall-clock "
        "reads and global random calls; a DTC with findings fails",
    )
    group.addoption(
        "--beatlog-coverage",
        action="store_true",
        dest="beatlog_coverage",
        help="show which behavior states the DTCs that ran exercise and the changes between "
        "them from one heartbeat to the next, and the states declared or seen by earlier "
        "runs that none reaches",
    )
    group.addoption(
        "--beatlog-coverage-json",
        type=Path,
        metavar="FILE",
        dest="beatlog_coverage_json",
        help="write the transition coverage of the DTCs that ran as JSON",
    )
    group.addoption(
        "--beatlog-variants",
        type=int,
        metavar="N",
        dest="beatlog_variants",
        help="also run variants 1..N of each DTC that declares variants ([variants]), each "
        "a test of its own (NAME[variant-N]); a failing one is written as a spec beside "
        "its DTC (default: each DTC's own count)",
    )
    group.addoption(
        "--beatlog-break-at",
        type=int,
        metavar="CYCLE",
        dest="beatlog_break_at",
        help="stop in the debugger just before the behaviors update in this cycle of the "
        "one DTC selected",
    )
    group.addoption(
        "--beatlog-break-on-divergence",
        action="store_true",
        dest="beatlog_break_on_divergence",
        help="replay each failing DTC again and stop in the debugger at its first divergence",
    )
    parser.addini(
        "beatlog_collect",
        type="bool",
        default=True,
        help="collect *.dtc.toml files as beatlog deterministic test cases",
    )


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "dtc: a beatlog deterministic test case (*.dtc.toml)")
    break_at = config.getoption("beatlog_break_at")
    break_on_divergence = config.getoption("beatlog_break_on_divergence")
    if break_at is not None and break_at < 0:
        raise pytest.UsageError(f"--beatlog-break-at: must be 0 or more, got {break_at}")
    variants = config.getoption("beatlog_variants")
    if variants is not None and variants < 0:
        raise pytest.UsageError(f"--beatlog-variants: must be 0 or more, got {variants}")
    if break_at is not None or break_on_divergence:
        if getattr(config.option, "numprocesses", None) and config.option.dist != "no":
            raise pytest.UsageError(
                "the beatlog break points stop in the debugger of this process: "
                "run without pytest-xdist's -n (or with -n 0)"
            )
        if config.option.usepdb_cls is None:  # pytest's pdb, quitting wherever it stops
            config.option.usepdb_cls = ("beatlog.replay.debugger", "Debugger")
    coverage = config.getoption("beatlog_coverage")
    coverage_json = config.getoption("beatlog_coverage_json")
    worker = hasattr(config, "workerinput")  # an xdist worker's run
    options = SpecOptions(
        update=UpdateMode.parse(config.getoption("beatlog_update")),
        audit=config.getoption("beatlog_audit"),
        break_at=break_at,
        break_on_divergence=break_on_divergence,
        coverage=(coverage or coverage_json is not None) and not worker,
    )
    config.stash[RUN] = BeatlogRun(
        options,
        root=config.rootpath,
        coverage=coverage,
        coverage_json=None
        if coverage_json is None
        else config.invocation_params.dir / coverage_json,
        variants=variants,
        worker=worker,
    )
    config.pluginmanager.register(config.stash[RUN], "beatlog-run")


def pytest_collect_file(parent: pytest.Collector, file_path: Path) -> pytest.Collector | None:
    if file_path.name.endswith(SPEC_SUFFIX) and parent.config.getini("beatlog_collect"):
        return DtcFile.from_parent(parent, path=file_path)
    return None


@pytest.fixture
def beatlog_replay(request: pytest.FixtureRequest) -> Callable[..., ReplayResult]:
    """Replay a session log in an ordinary test; a divergence fails the test readably.

    ``beatlog_replay(log, system, **options)`` takes the same arguments as
    :func:`beatlog.replay` and returns its result when the replay passes. A relative
    ``log`` is found beside the test file, as a spec's is beside the spec, and a
    ``module:factory`` system also imports from the test's folder and project root. A
    log that cannot be read (missing, corrupt, not fitting the system) fails the test
    with one line naming the file.
    """

    def run(log: str | Path, system: System | str, **options: Any) -> ReplayResult:
        from beatlog.project.usercode import importable_near  # noqa: PLC0415
        from beatlog.replay.judge import replay  # noqa: PLC0415 - see the imports

        try:
            with importable_near(request.path), quitting_as_pytest():
                result = replay(request.path.parent / log, system, **options)
        except BeatlogError as exc:
            pytest.fail(str(exc), pytrace=False)
        if not result.ok:
            pytest.fail(failure_text(result), pytrace=False)
        return result

    return run
