"""The ``beatlog`` entry point: one clean line and exit code 2 for every bad input, the
user's code imported from where the command runs, and a ``--help`` page for every
subcommand of the table, with what it does, its defaults and the exit codes."""

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

from beatlog.cli.commands import COMMANDS
from beatlog.cli.main import EXIT_CODES, main
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
from tests.specs import PROBE, write_spec
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


def spec(tmp_path: Path) -> Path:
    return write_spec(tmp_path, "walk", "walk.beatlog")


BAD_LOGS = [
    pytest.param(missing, "no such file", id="missing"),
    pytest.param(empty, "empty file", id="empty"),
    pytest.param(garbage, "not a session log (not an MCAP file)", id="garbage"),
    pytest.param(
        foreign, "an MCAP file with profile 'ros2', not a beatlog session log", id="foreign-mcap"
    ),
    pytest.param(cut_before_header, "cut off before its session header", id="cut-before-header"),
    pytest.param(directory, "is a directory, not a session log", id="directory"),
    pytest.param(spec, "a DTC spec, not a session log (beatlog test runs it)", id="spec"),
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


@pytest.mark.parametrize("way", ["console script", "python -m beatlog"])
def test_the_command_reports_a_missing_file_in_one_line(tmp_path: Path, way: str) -> None:
    script = shutil.which("beatlog", path=str(Path(sys.executable).parent))
    assert script is not None
    command = [script] if way == "console script" else [sys.executable, "-m", "beatlog"]
    log = tmp_path / "missing.beatlog"

    done = subprocess.run(
        [*command, "show", str(log)], capture_output=True, text=True, timeout=60, check=False
    )

    assert done.returncode == 2
    assert done.stdout == ""
    assert done.stderr == f"beatlog: error: {log}: no such file\n"


# the help pages

RUN_NO_USER_CODE = ["show", "upgrade-baselines", "help"]
"""The commands whose ``--verbose`` would do nothing: they never import the user's code."""
SUBCOMMANDS = [
    "record",
    "replay",
    "test",
    "shrink",
    "review",
    "approve",
    "upgrade-baselines",
    "show",
    "plot",
    "export",
    "import-bag",
    "help",
    "demo",
]
"""Every subcommand, in the order ``beatlog --help`` lists them."""


def help_page(command: str, capsys: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(SystemExit) as exited:
        main([command, "--help"])
    assert exited.value.code == 0
    return capsys.readouterr().out


@pytest.mark.parametrize("command", SUBCOMMANDS)
def test_every_help_page_describes_the_command_its_arguments_and_exit_codes(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    page = help_page(command, capsys)
    description = page.split("\n\n")[1]
    positionals = page.partition("positional arguments:\n")[2].partition("\n\n")[0]

    assert description.endswith(".")
    assert all(len(line.split()) > 1 for line in positionals.splitlines())
    assert page.rstrip().endswith(EXIT_CODES.rstrip())
    codes = page.partition("exit codes:\n")[2].splitlines()
    assert [line.split()[0] for line in codes] == ["0", "1", "2", "5", "130", "143"]


@pytest.mark.parametrize(
    ("command", "default"),
    [
        ("record", "heartbeat period in ms (default: 30.0)"),
        ("record", "(default: 1.0)"),
        ("demo", "(default: beatlog-demo)"),
        ("demo", "(default: 20.0)"),
        ("test", "(default: the current folder)"),
    ],
)
def test_help_pages_show_defaults(
    command: str, default: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert default in " ".join(help_page(command, capsys).split())


def test_test_help_says_what_k_and_repeated_tags_mean(
    capsys: pytest.CaptureFixture[str],
) -> None:
    page = " ".join(help_page("test", capsys).split())

    helps = re.search(r" -k EXPRESSION (.*) --tag TAG (.*) -x, --exitfirst, --fail-fast ", page)
    assert helps is not None, page
    assert helps.groups() == (
        "only DTCs matching this expression, as pytest's -k: words matched against names and "
        "tags, with and, or, not and parentheses (e.g. -k 'touch or pat'); the names are the "
        "DTC's, its spec file's and its folders' below the rootdir",
        "only DTCs with this tag; given more than once, only DTCs with every tag given",
    )


def test_the_top_level_help_ends_with_the_exit_codes(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["--help"])

    assert exited.value.code == 0
    assert capsys.readouterr().out.rstrip().endswith(EXIT_CODES.rstrip())


@pytest.mark.parametrize(
    "command", [name for name in SUBCOMMANDS if name not in {"test", *RUN_NO_USER_CODE}]
)
def test_verbose_says_what_it_does_for_the_command_at_hand(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert verbose_help(command, capsys) == (
        "also print the traceback of user code that failed to load"
    )


@pytest.mark.parametrize("command", RUN_NO_USER_CODE)
def test_a_command_that_runs_no_user_code_offers_no_verbose(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert "--verbose" not in help_page(command, capsys)


def test_test_verbose_lists_every_dtc(capsys: pytest.CaptureFixture[str]) -> None:
    assert verbose_help("test", capsys) == (
        "list every DTC in the summary, and print the traceback of user code that failed to load"
    )


def verbose_help(command: str, capsys: pytest.CaptureFixture[str]) -> str:
    """What the help page of ``command`` says ``--verbose`` does, on one line."""
    page = " ".join(help_page(command, capsys).split())
    verbose = re.search(r" -v, --verbose (.*?) (-|exit codes:)", page)
    assert verbose is not None, page
    return verbose[1]


def test_review_help_says_it_asks_about_each_change_and_loss_and_approve_does_not_ask(
    capsys: pytest.CaptureFixture[str],
) -> None:
    review = " ".join(help_page("review", capsys).split())
    approve = " ".join(help_page("approve", capsys).split())

    assert review.startswith(
        "usage: beatlog review [-h] [-v] [paths ...] Show each pending baseline change with "
        "what it loses, and ask whether to accept, reject or skip it (and each loss); "
        "accepting writes the approved baseline."
    )
    assert "Accept every pending baseline of DTC specs without asking, naming each loss" in approve


def test_the_commands_are_those_of_the_table_once_each_in_its_order(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(SystemExit):
        main(["--help"])
    usage = capsys.readouterr().out

    assert list(COMMANDS) == SUBCOMMANDS
    assert usage.count("{" + ",".join(COMMANDS) + "}") == 2
