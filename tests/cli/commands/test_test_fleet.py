"""``beatlog test --logs GLOB --system MODULE:FACTORY``: a fleet's logs replayed with no
spec per log, with the reports and exit codes of a suite of specs."""

from __future__ import annotations

import re
import shlex
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

import fsspec
import pytest

from beatlog.baseline.file import expected_path
from tests.commands import (
    Beatlog,
    assert_error,
    assert_error_matching,
    cannot_import,
    closing_counts,
)
from tests.conftest import RecordFn
from tests.specs import CHANGED, FIRST_CHANGED_CYCLE, PROBE, write_spec
from tests.text import table_row, whole_lines

pytestmark = pytest.mark.usefixtures("wide_plain_console")


@pytest.fixture
def logs(tmp_path: Path, record_probe: RecordFn) -> Path:
    """A fleet's folder: two sessions of one day, one of the next in a subfolder."""
    (tmp_path / "fleet" / "tuesday").mkdir(parents=True)
    for name in ("fleet/dock.beatlog", "fleet/patrol.beatlog", "fleet/tuesday/yard.beatlog"):
        record_probe(300, name=name)
    return tmp_path / "fleet"


def test_every_log_that_matches_is_replayed_as_a_dtc(beatlog: Beatlog, logs: Path) -> None:
    run = beatlog("test", "--logs", f"{logs}/**/*.beatlog", "--system", PROBE)

    assert run.code == 0, run.err
    for name in ("dock", "patrol", "yard"):
        assert table_row(run.out, name)[:4] == [name, "passed", "300", "9.0 s"]
    assert closing_counts(run.out) == "3 passed, 0 failed"


def test_a_fleet_log_that_diverges_fails_and_its_rerun_command_reproduces_it(
    beatlog: Beatlog, logs: Path, tmp_path: Path
) -> None:
    report = tmp_path / "fleet.xml"
    run = beatlog("test", "--logs", f"{logs}/*.beatlog", "--system", CHANGED, "--junit-xml", report)

    assert run.code == 1
    assert (
        f"first divergence: cycle {FIRST_CHANGED_CYCLE}, t = 0.660 s, state changes"
        in whole_lines(run.out)
    )
    rerun = f"beatlog test --logs {logs}/dock.beatlog --system {CHANGED}"
    assert f"reproduce: {rerun}" in whole_lines(run.out)
    cases = ET.parse(report).getroot().iter("testcase")
    assert [case.get("name") for case in cases] == ["dock", "patrol"]

    again = beatlog(*shlex.split(rerun)[1:])

    assert again.code == 1
    assert (
        f"first divergence: cycle {FIRST_CHANGED_CYCLE}, t = 0.660 s, state changes"
        in whole_lines(again.out)
    )


def test_a_log_that_cannot_be_read_is_an_error_of_its_dtc(beatlog: Beatlog, logs: Path) -> None:
    (logs / "broken.beatlog").write_bytes(b"not a log")

    run = beatlog("test", "--logs", f"{logs}/*.beatlog", "--system", PROBE)

    assert run.code == 2
    broken = logs / "broken.beatlog"
    assert run.err == (
        f"beatlog: error: broken ({broken}): {broken}: not a session log (not an MCAP file)\n"
    )
    assert closing_counts(run.out) == "2 passed, 0 failed, 1 error"


@pytest.mark.parametrize(
    ("option", "reference", "problem"),
    [
        ("--system", "tests.nowhere:system", cannot_import("tests.nowhere")),
        ("--system", "tests.conftest:nothing", re.escape("tests.conftest has no nothing")),
        ("--perception", "tests.conftest:nothing", re.escape("tests.conftest has no nothing")),
    ],
)
def test_a_reference_that_cannot_be_built_is_one_line_for_the_run_not_one_per_log(
    beatlog: Beatlog, logs: Path, option: str, reference: str, problem: str
) -> None:
    system = reference if option == "--system" else PROBE
    extra = (option, reference) if option == "--perception" else ()

    run = beatlog("test", "--logs", f"{logs}/**/*.beatlog", "--system", system, *extra)

    assert_error_matching(run, f"{option} {re.escape(repr(reference))}: {problem}")


def test_a_fleet_run_can_be_sharded(beatlog: Beatlog, logs: Path) -> None:
    runs = [
        beatlog("test", "--logs", f"{logs}/**/*.beatlog", "--system", PROBE, "--shard", shard)
        for shard in ("1/2", "2/2")
    ]

    assert [closing_counts(run.out) for run in runs] == [
        "2 passed, 0 failed",
        "1 passed, 0 failed",
    ]


def test_logs_behind_a_file_url_are_replayed(beatlog: Beatlog, logs: Path) -> None:
    run = beatlog("test", "--logs", f"file://{logs}/*.beatlog", "--system", CHANGED)

    assert run.code == 1
    assert (
        f"reproduce: beatlog test --logs file://{logs}/dock.beatlog "
        "--system tests.conftest:probe_system_changed" in whole_lines(run.out)
    )


@pytest.fixture
def memory_logs(logs: Path) -> Iterator[str]:
    """The fleet's logs in fsspec's in-memory filesystem, in a folder of this test's own."""
    filesystem = fsspec.filesystem("memory")
    folder = f"/{logs.parent.name}"
    filesystem.put(str(logs), folder, recursive=True)
    yield f"memory://{folder}"
    filesystem.rm(folder, recursive=True)


def test_logs_behind_any_fsspec_url_are_replayed(beatlog: Beatlog, memory_logs: str) -> None:
    run = beatlog("test", "--logs", f"{memory_logs}/**/*.beatlog", "--system", PROBE)

    assert run.code == 0, run.err
    assert closing_counts(run.out) == "3 passed, 0 failed"


def test_a_pattern_that_matches_nothing_is_named(beatlog: Beatlog, logs: Path) -> None:
    pattern = f"{logs}/*.mcap"

    run = beatlog("test", "--logs", pattern, "--system", PROBE)

    assert_error(run, f"--logs {pattern}: no log matches")


@pytest.mark.parametrize(
    ("arguments", "problem"),
    [
        (
            ["--logs", "fleet/*.beatlog"],
            "--logs needs --system MODULE:FACTORY to replay the logs against",
        ),
        (["--system", PROBE], "--system and --perception go with --logs: a spec names its own"),
        (
            ["--perception", PROBE],
            "--system and --perception go with --logs: a spec names its own",
        ),
        (["specs", "--logs", "fleet/*", "--system", PROBE], "give DTC specs or --logs, not both"),
        (
            ["--logs", "fleet/*", "--system", PROBE, "--update"],
            "--update writes the baselines of specs; --logs runs have none",
        ),
        (
            ["--logs", "fleet/*", "--system", "tests.conftest"],
            "--system: expected module:factory, got 'tests.conftest'",
        ),
    ],
)
def test_options_that_do_not_go_together_are_usage_errors(
    beatlog: Beatlog, arguments: list[str], problem: str
) -> None:
    assert_error(beatlog("test", *arguments), problem)


def test_a_fleet_run_reads_no_baseline_and_looks_for_no_orphan(
    beatlog: Beatlog, logs: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A spec's baseline beside a log is not the log's; the specs' folder is not looked at."""
    write_spec(logs, "dock", logs / "dock.beatlog")
    expected_path(logs / "dock.dtc.toml").write_text("not a baseline", encoding="utf-8")
    expected_path(logs / "gone.dtc.toml").write_text("an orphan", encoding="utf-8")
    monkeypatch.chdir(logs)

    run = beatlog("test", "--logs", "*.beatlog", "--system", PROBE)
    specs = beatlog("test")

    assert run.code == 0, run.err
    assert "orphaned baseline" not in run.out
    assert specs.code == 2  # the spec's baseline is read, and is no baseline
    assert "orphaned baseline gone.dtc.expected: no spec beside it; delete it" in whole_lines(
        specs.out
    )
