"""The ``beatlog`` entry point: one clean line and exit code 2 for every bad input, and
the user's code imported from where the command runs."""

from __future__ import annotations

import inspect
import re
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from mcap.writer import Writer

from beatlog.log.writer import SessionLogWriter
from tests.commands import (
    Beatlog,
    assert_error,
    assert_error_matching,
    cannot_import,
    failing_line,
)
from tests.conftest import RecordFn, broken_probe
from tests.crafting import session_header
from tests.specs import PROBE
from tests.text import frames

pytestmark = pytest.mark.usefixtures("wide_plain_console")


# bad input: one line on stderr naming the file and the problem


def missing(tmp_path: Path) -> Path:
    return tmp_path / "missing.beatlog"


def empty(tmp_path: Path) -> Path:
    path = tmp_path / "empty.beatlog"
    path.write_bytes(b"")
    return path


def garbage(tmp_path: Path) -> Path:
    path = tmp_path / "garbage.beatlog"
    path.write_bytes(b"\x00\xff not a log \xfe" * 100)
    return path


def foreign(tmp_path: Path) -> Path:
    path = tmp_path / "bag.mcap"
    with path.open("wb") as file:
        writer = Writer(file)
        writer.start(profile="ros2", library="rosbag2")
        writer.finish()  # type: ignore[no-untyped-call]
    return path


def cut_before_header(tmp_path: Path) -> Path:
    path = tmp_path / "cut.beatlog"
    SessionLogWriter(path, session_header()).close()
    path.write_bytes(path.read_bytes()[:100])
    return path


def directory(tmp_path: Path) -> Path:
    path = tmp_path / "logs"
    path.mkdir()
    return path


BAD_LOGS = [
    pytest.param(missing, "no such file", id="missing"),
    pytest.param(empty, "empty file", id="empty"),
    pytest.param(garbage, "not a session log (not an MCAP file)", id="garbage"),
    pytest.param(
        foreign, "an MCAP file with profile 'ros2', not a beatlog session log", id="foreign-mcap"
    ),
    pytest.param(cut_before_header, "cut off before its session header", id="cut-before-header"),
    pytest.param(directory, "is a directory, not a session log", id="directory"),
]


@pytest.mark.parametrize(("make", "problem"), BAD_LOGS)
@pytest.mark.parametrize("command", [["show"], ["replay", "--system", PROBE]])
def test_a_bad_log_is_one_line_naming_the_file(
    beatlog: Beatlog,
    tmp_path: Path,
    make: Callable[[Path], Path],
    problem: str,
    command: list[str],
) -> None:
    log = make(tmp_path)

    run = beatlog(command[0], log, *command[1:])

    assert_error(run, f"{log}: {problem}")


@pytest.mark.parametrize(
    ("reference", "problem"),
    [
        ("tests.conftest", re.escape("expected module:factory, e.g. mypkg.robot:system")),
        ("tests.no_such_module:system", cannot_import("tests.no_such_module")),
        ("tests.conftest:no_such_factory", re.escape("tests.conftest has no no_such_factory")),
        (
            "tests.systems:not_a_system",
            re.escape("built a dict, not a system (it needs robot_state, behaviors and update)"),
        ),
        (
            "tests.conftest:broken_probe",
            re.escape(
                "the factory raised RuntimeError: the arena map is missing "
                f"({failing_line(broken_probe)})"
            ),
        ),
    ],
)
def test_a_bad_system_reference_is_one_line_naming_it(
    beatlog: Beatlog, record_probe: RecordFn, reference: str, problem: str
) -> None:
    run = beatlog("replay", record_probe(10), "--system", reference)

    assert_error_matching(run, f"{re.escape(repr(reference))}: {problem}")


def test_verbose_shows_the_traceback_of_a_factory_that_failed(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    reference = "tests.conftest:broken_probe"
    log = record_probe(10)

    quiet = beatlog("replay", log, "--system", reference)
    verbose = beatlog("replay", log, "--system", reference, "-v")

    assert_error(
        quiet,
        f"{reference!r}: the factory raised RuntimeError: the arena map is missing "
        f"({failing_line(broken_probe)})",
    )
    assert verbose.code == 2
    assert verbose.out == ""
    assert verbose.err.startswith("Traceback (most recent call last):\n")
    assert (inspect.getsourcefile(broken_probe), "broken_probe") in frames(verbose.err)
    assert "beatlog/engine" not in verbose.err
    assert verbose.err.endswith(quiet.err)


@pytest.mark.parametrize(
    ("args", "problem"),
    [
        (
            ["replay", "x.beatlog", "--system", PROBE, "--frobnicate"],
            "unrecognized arguments: --frobnicate (see 'beatlog --help')",
        ),
        (
            ["record", "--robot", "r:robot", "-o", "x.beatlog", "--duration", "soon"],
            "argument --duration: not a number: 'soon' (see 'beatlog record --help')",
        ),
        (
            ["record", "--robot", "r:robot", "-o", "x.beatlog", "--duration", "-1"],
            "argument --duration: must be positive: '-1' (see 'beatlog record --help')",
        ),
        (
            ["record", "--robot", "r:robot", "-o", "x.beatlog", "--duration", "0"],
            "argument --duration: must be positive: '0' (see 'beatlog record --help')",
        ),
        (
            ["record", "--robot", "r:robot", "--duration", "1"],
            "the following arguments are required: -o/--output (see 'beatlog record --help')",
        ),
        (
            ["play", "x.beatlog"],
            "argument command: invalid choice: 'play' (choose from 'record', 'replay', 'test', "
            "'shrink', 'review', 'approve', 'upgrade-baselines', 'show', 'plot', 'export', "
            "'import-bag', 'help', 'demo') "
            "(see 'beatlog --help')",
        ),
        ([], "the following arguments are required: command (see 'beatlog --help')"),
    ],
    ids=[
        "unknown-flag",
        "non-numeric-duration",
        "negative-duration",
        "zero-duration",
        "no-output",
        "unknown-command",
        "no-command",
    ],
)
def test_a_bad_option_is_one_line_pointing_at_help(
    beatlog: Beatlog, args: list[str], problem: str
) -> None:
    run = beatlog(*args)

    assert_error(run, problem)


def test_a_system_in_the_working_directory_can_be_named(
    beatlog: Beatlog,
    record_probe: RecordFn,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """As with ``python -m``, the console script imports from where it is run."""
    log = record_probe(30)
    project = tmp_path / "project"
    project.mkdir()
    (project / "probe_under_test.py").write_text(
        "from tests.conftest import probe_system as system\n"
    )
    monkeypatch.chdir(project)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", str(project))])
    monkeypatch.delitem(sys.modules, "probe_under_test", raising=False)

    run = beatlog("replay", log, "--system", "probe_under_test:system")

    assert run.code == 0, run.err
    assert run.out.startswith("PASS")


def test_the_console_script_reports_a_missing_file_in_one_line(tmp_path: Path) -> None:
    script = shutil.which("beatlog", path=str(Path(sys.executable).parent))
    command = [script] if script else [sys.executable, "-m", "beatlog.cli.main"]
    log = tmp_path / "missing.beatlog"

    done = subprocess.run(
        [*command, "show", str(log)], capture_output=True, text=True, timeout=60, check=False
    )

    assert done.returncode == 2
    assert done.stdout == ""
    assert done.stderr == f"beatlog: error: {log}: no such file\n"
