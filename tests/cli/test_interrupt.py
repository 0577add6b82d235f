"""Ctrl-C: every command stops at once, stops its children, prints what is complete,
writes no half-written report or pending file, and exits 130.

Each test starts ``beatlog`` in its own process group, waits until it is at work, and
sends SIGINT to the group, as a terminal does.
"""

from __future__ import annotations

import os
import re
import signal
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import pytest

from beatlog.log.reader import LogStatus, SessionLogReader
from tests.cli.slow_systems import MARKERS
from tests.commands import Run, closing_counts, signalled
from tests.conftest import RecordFn
from tests.specs import CHANGED, PROBE, write_spec
from tests.text import table_row, whole_lines

SLOW = "tests.cli.slow_systems:slow_system"
SLOW_IN_AUDIT = "tests.cli.slow_systems:slow_in_audit_system"
ABANDONING = "tests.cli.slow_systems:abandoning_system"


@pytest.fixture
def markers(tmp_path: Path) -> Path:
    folder = tmp_path / "markers"
    folder.mkdir()
    return folder


@pytest.fixture
def press_ctrl_c(markers: Path) -> Callable[..., Run]:
    """Run ``beatlog ARGS``, press Ctrl-C once ``ready()`` holds, and collect the ending."""

    def run(args: Sequence[str | Path], ready: Callable[[], bool]) -> Run:
        env = {**os.environ, MARKERS: str(markers), "COLUMNS": "200"}
        env.pop("PYTHONHASHSEED", None)
        return signalled(args, ready, signal.SIGINT, env=env, group=True)

    return run


def marked(markers: Path, count: int = 1) -> Callable[[], bool]:
    """Ready once ``count`` processes stepped a slow system, and a moment later, so the
    outcomes already complete have reached the parent."""

    def ready() -> bool:
        if len(list(markers.iterdir())) < count:
            return False
        time.sleep(0.5)
        return True

    return ready


def created(path: Path) -> Callable[[], bool]:
    """Ready a second after ``path`` appears: the command is recording by then."""

    def ready() -> bool:
        if not path.exists():
            return False
        time.sleep(1)
        return True

    return ready


@pytest.fixture
def suite(tmp_path: Path, record_probe: RecordFn) -> Path:
    """A DTC that passes at once, a failing one, then two that replay for 30 s each."""
    log = record_probe(300)
    specs = tmp_path / "specs"
    write_spec(specs, "a-fast", log, PROBE)
    write_spec(specs, "b-changed", log, CHANGED)
    write_spec(specs, "c-slow", log, SLOW)
    write_spec(specs, "d-slow", log, SLOW)
    return specs


def assert_stopped(run: Run) -> None:
    assert run.code == 130, run
    assert "Traceback" not in run.err
    assert run.err.endswith("beatlog: interrupted\n"), run.err


def assert_complete_results_printed(run: Run) -> None:
    assert table_row(run.out, "a-fast")[:2] == ["a-fast", "passed"]
    assert table_row(run.out, "b-changed")[:2] == ["b-changed", "failed"]
    assert closing_counts(run.out) == "1 passed, 1 failed, 2 not run"


@pytest.mark.slow  # 2 s or more: CI's slow run has it
@pytest.mark.parametrize("jobs", ["1", "2"])
def test_ctrl_c_stops_a_suite_and_prints_what_is_complete(
    press_ctrl_c: Callable[..., Run], suite: Path, markers: Path, jobs: str
) -> None:
    run = press_ctrl_c(["test", "-j", jobs, suite], marked(markers, int(jobs)))

    assert_stopped(run)
    assert_complete_results_printed(run)
    assert closing_counts(run.out) == "1 passed, 1 failed, 2 not run"


@pytest.mark.slow  # a local cluster starts in seconds: CI's slow run has it
@pytest.mark.parametrize("when", ["starting", "replaying"])
def test_ctrl_c_stops_a_suite_on_a_local_cluster_in_one_line(
    suite: Path, markers: Path, tmp_path: Path, when: str
) -> None:
    scratch = tmp_path / "scratch"  # where the cluster's workers make their folders
    scratch.mkdir()
    env = {**os.environ, MARKERS: str(markers), "TMPDIR": str(scratch)}
    ready = marked(markers, 2) if when == "replaying" else lambda: any(scratch.rglob("worker-*"))

    run = signalled(["test", "--dask", "local:2", suite], ready, signal.SIGINT, env=env, group=True)

    assert (run.code, run.err) == (130, "beatlog: interrupted\n")


@pytest.mark.parametrize("jobs", ["1", pytest.param("2", marks=pytest.mark.slow)])
def test_ctrl_c_stops_the_audit_interpreters(
    press_ctrl_c: Callable[..., Run],
    tmp_path: Path,
    record_probe: RecordFn,
    markers: Path,
    jobs: str,
) -> None:
    log = record_probe(300)
    specs = tmp_path / "specs"
    for name in ("a", "b", "c"):
        write_spec(specs, name, log, SLOW_IN_AUDIT)

    run = press_ctrl_c(["test", "--audit", "-j", jobs, specs], marked(markers, 2))

    assert_stopped(run)
    assert closing_counts(run.out) == "0 passed, 0 failed, 3 not run"


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_ctrl_c_writes_no_report_and_no_pending_file(
    press_ctrl_c: Callable[..., Run], suite: Path, markers: Path, tmp_path: Path
) -> None:
    html, junit = tmp_path / "report.html", tmp_path / "report.xml"

    run = press_ctrl_c(
        ["test", "-j", "2", "--update", "--html", html, "--junit-xml", junit, suite],
        marked(markers, 2),
    )

    assert_stopped(run)
    assert_complete_results_printed(run)
    assert sorted(path.name for path in suite.iterdir()) == [
        "a-fast.dtc.toml",
        "b-changed.dtc.toml",
        "c-slow.dtc.toml",
        "d-slow.dtc.toml",
    ]
    assert sorted(tmp_path.iterdir()) == sorted(
        [tmp_path / "markers", tmp_path / "probe.beatlog", suite]
    )


def test_ctrl_c_stops_a_replay(
    press_ctrl_c: Callable[..., Run], record_probe: RecordFn, markers: Path
) -> None:
    run = press_ctrl_c(["replay", record_probe(300), "--system", SLOW], marked(markers))

    assert_stopped(run)
    assert run.out == ""


def test_ctrl_c_warns_of_nothing_it_abandoned(
    press_ctrl_c: Callable[..., Run], record_probe: RecordFn, markers: Path
) -> None:
    run = press_ctrl_c(["replay", record_probe(30), "--system", ABANDONING], marked(markers))

    assert (run.code, run.err) == (130, "beatlog: interrupted\n")


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_ctrl_c_stops_a_shrink_and_writes_no_spec(
    press_ctrl_c: Callable[..., Run], record_probe: RecordFn, markers: Path, tmp_path: Path
) -> None:
    spec = write_spec(tmp_path, "slow", record_probe(300), SLOW)

    run = press_ctrl_c(["shrink", spec], marked(markers))

    assert_stopped(run)
    assert run.out == ""
    assert not (tmp_path / "slow.shrunk.dtc.toml").exists()


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_ctrl_c_ends_a_recording_with_a_complete_log(
    press_ctrl_c: Callable[..., Run], tmp_path: Path
) -> None:
    out = tmp_path / "rover.beatlog"

    run = press_ctrl_c(
        ["record", "--robot", "beatlog_examples.rover:robot", "-o", out, "--duration", 600],
        created(out),
    )

    assert_stopped(run)
    with SessionLogReader(out) as reader:
        cycles = sum(1 for _ in reader.cycles())
        assert reader.status == LogStatus(complete=True, cycles=cycles)
        assert reader.end is not None
        assert reader.end.cycles == cycles > 0
    recorded, certified = whole_lines(run.out)[-2:]
    assert re.fullmatch(
        rf"recorded {cycles} cycles \(\d+\.\d\d s, \d+ overruns\) to {re.escape(str(out))}",
        recorded,
    ), run.out
    assert certified == f"certified: the log replays against a fresh system ({cycles} cycles)"


@pytest.mark.slow
def test_ctrl_c_stops_the_demo(press_ctrl_c: Callable[..., Run], tmp_path: Path) -> None:
    log = tmp_path / "demo" / "dog.beatlog"

    run = press_ctrl_c(
        ["demo", "--duration", 600, "--out", tmp_path / "demo"],
        created(log),
    )

    assert_stopped(run)
