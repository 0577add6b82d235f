"""The ``beatlog`` command: verdicts as exit codes, and one clean line for every bad input."""

from __future__ import annotations

import itertools
import json
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import pytest
from mcap.writer import Writer

from beatlog.analysis.summary import summarize
from beatlog.cli.main import EXIT_CODES, main
from beatlog.log.reader import SessionLogReader
from beatlog.log.writer import SessionLogWriter
from beatlog.record.recorder import Recorder
from tests.commands import Beatlog, assert_one_line_error
from tests.conftest import RecordFn, distances
from tests.factories import session_header, vouch, with_damaged_index
from tests.specs import CHANGED, FIRST_CHANGED_CYCLE, PROBE
from tests.systems import quiet_system

pytestmark = pytest.mark.usefixtures("wide_plain_console")


# replay


def test_replay_passes_a_log_against_the_system_that_recorded_it(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    log = record_probe(300)

    run = beatlog("replay", log, "--system", PROBE)

    assert run.code == 0
    assert run.out.startswith(
        f"PASS {log}  300 cycles, 43 state changes, 453 outputs, 60 draws checked; "
        "9.0 s robot time in "
    )
    assert run.out.endswith("; log complete\n")
    assert run.err == ""


def test_replay_without_a_system_uses_and_names_the_one_the_project_vouches_for(
    beatlog: Beatlog, record_probe: RecordFn, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_probe(300)
    vouch(tmp_path, PROBE)
    monkeypatch.chdir(tmp_path)

    run = beatlog("replay", log)

    assert run.code == 0
    assert run.out.startswith(f"PASS {log}")
    assert run.err == (
        f"beatlog: replaying against {PROBE}, as recorded in {log} "
        "and listed in the project's [tool.beatlog] systems\n"
    )


def test_replay_without_a_system_of_a_log_that_records_none_is_one_line(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    log = record_probe(30, system_ref="")

    run = beatlog("replay", log)

    assert_one_line_error(run, f"{log}: records no system; name one (module:factory)")


TRAP = "import pathlib\npathlib.Path('sprung').write_text('imported')\ndef trap(): pass\n"
"""A module beside the log that leaves a file ``sprung`` when it is imported."""


@pytest.mark.parametrize("recorded", ["booby:trap", "tempfile:mkdtemp", "this:s", PROBE])
def test_a_log_never_chooses_the_code_replay_imports(
    beatlog: Beatlog,
    record_probe: RecordFn,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    recorded: str,
) -> None:
    (tmp_path / "booby.py").write_text(TRAP, encoding="utf-8")
    vouch(tmp_path, "robot.nav:system")
    monkeypatch.chdir(tmp_path)
    log = record_probe(30, system_ref=recorded)
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temporary))
    imported = set(sys.modules)

    run = beatlog("replay", log)

    assert_one_line_error(
        run,
        f"{log}: records the system {recorded!r}, which this project does not vouch for",
        f"[tool.beatlog] systems in {tmp_path / 'pyproject.toml'}",
    )
    assert not (tmp_path / "sprung").exists()
    assert set(sys.modules) - imported <= {"beatlog.replay.judge", "beatlog.report.console"}
    assert list(temporary.iterdir()) == []


def test_a_hostile_header_prints_nothing_of_the_module_it_names(
    record_probe: RecordFn, tmp_path: Path
) -> None:
    log = record_probe(30, system_ref="this:s")

    run = subprocess.run(
        [sys.executable, "-m", "beatlog.cli.main", "replay", str(log)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=60,
        check=False,
    )

    assert run.returncode == 2
    assert run.stdout == ""
    assert run.stderr == (
        f"beatlog: error: {log}: records the system 'this:s', which this project does not "
        "vouch for; name it (--system, or system = in the spec) or list it under "
        "[tool.beatlog] systems in a pyproject.toml\n"
    )


def test_replay_fails_at_the_first_changed_cycle_and_says_how_to_reproduce(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    log = record_probe(300)

    run = beatlog("replay", log, "--system", CHANGED)

    assert run.code == 1
    assert run.out.startswith(f"FAIL {log}")
    assert f"first divergence: cycle {FIRST_CHANGED_CYCLE}," in run.out
    assert "behavior state changes differ from the recording" in run.out
    assert f"reproduce: beatlog replay {log} --system {CHANGED}" in run.out
    assert run.err == ""


def test_replay_maps_robot_state_fields_renamed_or_retyped_since_the_recording(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    log = record_probe(300)
    renamed = ("--system", "tests.systems:probe_system_ranged")
    retyped = ("--system", "tests.systems:probe_system_centimetred")

    assert beatlog("replay", log, *renamed, "--rename-field", "distance=range").code == 0
    converted = ("--convert-field", "distance=tests.systems:centimetres")
    assert beatlog("replay", log, *retyped, *converted).code == 0
    assert_one_line_error(
        beatlog("replay", log, *renamed),
        "field 'distance' is gone; the system has 'range' (number) in its place: if "
        'renamed, add field_renames = { distance = "range" } to the spec (beatlog replay: '
        "--rename-field distance=range)",
    )
    assert_one_line_error(
        beatlog("replay", log, *renamed, "--rename-field", "distance"),
        "argument --rename-field: expected NAME=VALUE: 'distance'",
    )
    failing = ("--convert-field", "distance=tests.systems:centimetres_unless_close")
    assert_one_line_error(
        beatlog("replay", log, *retyped, *failing),
        f"{log}: robot state of cycle 46: field 'distance': "
        "tests.systems:centimetres_unless_close raised ValueError: 0.08 m is too close",
    )


def test_replay_json_reports_the_divergence_for_machines(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    log = record_probe(300)

    run = beatlog("replay", log, "--system", CHANGED, "--json")

    assert run.code == 1
    result = json.loads(run.out)
    assert result["ok"] is False
    assert result["log"] == str(log)
    assert result["divergence"]["cycle"] == FIRST_CHANGED_CYCLE
    assert result["divergence"]["kind"] == "state changes"
    assert result["divergence"]["robot_state"]["distance"] == distances(300)[FIRST_CHANGED_CYCLE]
    assert result["divergent_cycles"] == 1


def test_replay_json_of_a_pass(beatlog: Beatlog, record_probe: RecordFn) -> None:
    run = beatlog("replay", record_probe(300), "--system", PROBE, "--json")

    assert run.code == 0
    result = json.loads(run.out)
    assert result["ok"] is True
    assert result["cycles"] == 300
    assert result["divergence"] is None
    assert result["status"] == {"complete": True, "cycles": 300, "problem": None}
    assert result["checked"] == {"state_changes": 43, "outputs": 453, "draws": 60, "samples": 0}


def test_replay_keep_going_counts_every_diverging_cycle(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    """A cycle diverges when near is in another state, or changes state at another time."""
    recorded = [d < 0.5 for d in distances(300)]
    changed = [d < 0.6 for d in distances(300)]
    diverging = sum(
        1
        for t in range(300)
        if recorded[t] != changed[t] or flips(recorded)[t] != flips(changed)[t]
    )

    run = beatlog("replay", record_probe(300), "--system", CHANGED, "--keep-going", "--json")

    assert run.code == 1
    result = json.loads(run.out)
    assert result["cycles"] == 300
    assert result["divergence"]["cycle"] == FIRST_CHANGED_CYCLE
    assert result["divergent_cycles"] == diverging
    assert result["status"] == {"complete": True, "cycles": 300, "problem": None}


def flips(near: list[bool]) -> list[bool]:
    """Whether near changed state in each cycle; it starts far."""
    return [now != before for before, now in zip([False, *near], near, strict=False)]


def cut_in_half(log: Path) -> Path:
    data = log.read_bytes()
    log.write_bytes(data[: len(data) // 2])
    return log


def test_a_truncated_log_fails_replay_unless_allowed(
    beatlog: Beatlog, record_chunked: RecordFn
) -> None:
    log = cut_in_half(record_chunked(300))
    with SessionLogReader(log) as reader:
        kept = sum(1 for _ in reader.cycles())
    assert 0 < kept < 300

    failed = beatlog("replay", log, "--system", PROBE)
    allowed = beatlog("replay", log, "--system", PROBE, "--allow-truncated")

    assert failed.code == 1
    assert f"first divergence: cycle {kept}," in failed.out
    assert "log ended" in failed.out
    assert f"the log ends early (truncated at cycle {kept}:" in failed.out
    assert allowed.code == 0
    assert allowed.out.startswith(f"PASS {log}  {kept} cycles")
    assert f"log truncated at cycle {kept}" in allowed.out


def test_a_replay_that_checks_nothing_is_bad_input_unless_allowed(
    beatlog: Beatlog, tmp_path: Path
) -> None:
    log = tmp_path / "killed.beatlog"
    with Recorder(tmp_path / "live.beatlog", quiet_system(), software="test"):
        log.write_bytes((tmp_path / "live.beatlog").read_bytes())  # killed before a cycle
    system = "tests.systems:quiet_system"

    refused = beatlog("replay", log, "--system", system, "--allow-truncated")
    allowed = beatlog("replay", log, "--system", system, "--allow-truncated", "--allow-empty")

    assert_one_line_error(refused)
    assert refused.err == (
        f"beatlog: error: {log}: the replay checked nothing (0 cycles); if nothing is meant "
        "to happen in it, accept it with --allow-empty (in a spec: allow_empty = true)\n"
    )
    assert allowed.code == 0
    assert allowed.out == (
        f"PASS {log}  0 cycles checked (allowed empty); 0.0 s robot time in under 1 ms; "
        "log truncated at cycle 0: the recording stopped before the log was closed\n"
    )


# show


def about_rows(out: str) -> dict[str, str]:
    """The name-value lines ``show`` prints above its behaviors table."""
    about = itertools.takewhile(lambda line: line.strip() != "behaviors", out.splitlines())
    pairs = (line.strip().partition("  ") for line in about)
    return {name: value.strip() for name, _, value in pairs}


def table_rows(out: str) -> list[list[str]]:
    """The cells of each row of the behaviors table."""
    rows = [line for line in out.splitlines() if line.startswith("│")]
    return [[cell.strip() for cell in row.split("│")[1:-1]] for row in rows]


def test_show_describes_a_log(beatlog: Beatlog, record_probe: RecordFn) -> None:
    log = record_probe(300, robot_id="probe-1")
    summary = summarize(log)

    run = beatlog("show", log)

    assert run.code == 0
    about = about_rows(run.out)
    assert about["log"] == str(log)
    assert about["status"] == "complete"
    assert about["robot"] == "probe-1"
    assert about["cycles"] == "300"
    assert "60 (randint 60)" in run.out
    assert table_rows(run.out) == [
        [str(index), name, str(count)]
        for index, (name, count) in enumerate(summary.transitions.items())
    ]
    assert [row[1] for row in table_rows(run.out)] == ["arbiter", "near", "dice"]


def test_show_says_a_cut_off_log_is_truncated(beatlog: Beatlog, record_chunked: RecordFn) -> None:
    log = cut_in_half(record_chunked(300))

    run = beatlog("show", log)

    assert run.code == 0
    assert "truncated at cycle" in run.out
    assert "unknown (no end record)" in run.out


def test_show_says_a_log_whose_index_is_damaged_holds_its_data_intact(
    tmp_path: Path, beatlog: Beatlog, record_probe: RecordFn
) -> None:
    log = with_damaged_index(record_probe(300), tmp_path / "index.beatlog")

    run = beatlog("show", log)

    assert run.code == 0
    assert about_rows(run.out)["status"] == (
        "index damaged, data intact: the summary does not match its CRC in the footer"
    )
    assert about_rows(run.out)["cycles"] == "300"


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
    pytest.param(garbage, "not a session log", id="garbage"),
    pytest.param(foreign, "profile 'ros2'", id="foreign-mcap"),
    pytest.param(cut_before_header, "cut off before its session header", id="cut-before-header"),
    pytest.param(directory, "is a directory", id="directory"),
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

    assert_one_line_error(run, f"{log}: ", problem)


@pytest.mark.parametrize(
    ("reference", "problem"),
    [
        ("tests.conftest", "expected module:factory"),
        ("tests.no_such_module:system", "cannot import tests.no_such_module"),
        ("tests.conftest:no_such_factory", "tests.conftest has no no_such_factory"),
        ("tests.systems:not_a_system", "built a dict, not a system"),
        ("tests.conftest:broken_probe", "raised RuntimeError: the arena map is missing"),
    ],
)
def test_a_bad_system_reference_is_one_line_naming_it(
    beatlog: Beatlog, record_probe: RecordFn, reference: str, problem: str
) -> None:
    run = beatlog("replay", record_probe(10), "--system", reference)

    assert_one_line_error(run, f"'{reference}': ", problem)


def test_verbose_shows_the_traceback_of_a_factory_that_failed(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    reference = "tests.conftest:broken_probe"
    log = record_probe(10)

    quiet = beatlog("replay", log, "--system", reference)
    verbose = beatlog("replay", log, "--system", reference, "-v")

    assert_one_line_error(quiet, "the factory raised RuntimeError: the arena map is missing")
    assert verbose.code == 2
    assert verbose.out == ""
    assert verbose.err.startswith("Traceback (most recent call last):\n")
    assert "in broken_probe" in verbose.err
    assert "beatlog/engine" not in verbose.err
    assert verbose.err.endswith(quiet.err)


@pytest.mark.parametrize(
    ("args", "problem"),
    [
        (["replay", "x.beatlog", "--system", PROBE, "--frobnicate"], "--frobnicate"),
        (["record", "--robot", "r:robot", "-o", "x.beatlog", "--duration", "soon"], "'soon'"),
        (["record", "--robot", "r:robot", "-o", "x.beatlog", "--duration", "-1"], "'-1'"),
        (["record", "--robot", "r:robot", "-o", "x.beatlog", "--duration", "0"], "'0'"),
        (["record", "--robot", "r:robot", "--duration", "1"], "-o/--output"),
        (["play", "x.beatlog"], "'play'"),
        ([], "command"),
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

    assert_one_line_error(run, problem, "--help')")


def test_record_refuses_to_overwrite_a_log(beatlog: Beatlog, record_probe: RecordFn) -> None:
    log = record_probe(10)
    before = log.read_bytes()

    run = beatlog("record", "--robot", "beatlog_examples.rover:robot", "-o", log, "--duration", 1)

    assert_one_line_error(run, f"{log}: already exists", "--force")
    assert log.read_bytes() == before


def test_record_into_a_missing_directory_is_one_line(beatlog: Beatlog, tmp_path: Path) -> None:
    out = tmp_path / "nowhere" / "rover.beatlog"

    run = beatlog("record", "--robot", "beatlog_examples.rover:robot", "-o", out, "--duration", 1)

    assert_one_line_error(run, f"{out}: directory {out.parent} does not exist")


def test_record_checks_the_system_reference_before_recording(
    beatlog: Beatlog, tmp_path: Path
) -> None:
    out = tmp_path / "rover.beatlog"

    run = beatlog(
        "record",
        "--robot",
        "beatlog_examples.rover:robot",
        "--system-ref",
        "nosuch:thing",
        "-o",
        out,
        "--duration",
        1,
    )

    assert_one_line_error(run, "'nosuch:thing': cannot import nosuch")
    assert not out.exists()


def test_record_needs_a_robot_not_a_system(beatlog: Beatlog, tmp_path: Path) -> None:
    out = tmp_path / "probe.beatlog"

    run = beatlog("record", "--robot", PROBE, "-o", out, "--duration", 1)

    assert_one_line_error(run, f"'{PROBE}': built a PriorityArbiter, not a robot")
    assert not out.exists()


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


# record: real time


@pytest.mark.slow
def test_record_writes_a_complete_log_that_replays(beatlog: Beatlog, tmp_path: Path) -> None:
    out = tmp_path / "rover.beatlog"

    recorded = beatlog(
        "record",
        "--robot",
        "beatlog_examples.rover:robot",
        "-o",
        out,
        "--duration",
        0.5,
        "--seed",
        11,
        "--robot-id",
        "rover-1",
        "--system-ref",
        "beatlog_examples.rover:system",
    )

    assert recorded.code == 0, recorded.err
    assert f"to {out}" in recorded.out
    with SessionLogReader(out) as reader:
        cycles = sum(1 for _ in reader.cycles())
        assert reader.status.complete
        assert reader.end is not None
        assert reader.end.cycles == cycles > 0
        assert reader.end.robot_time_ns >= 500_000_000
        assert reader.header.robot_id == "rover-1"
        assert reader.header.random_seed == 11
    assert f"recorded {cycles} cycles" in recorded.out
    replayed = beatlog("replay", out, "--system", "beatlog_examples.rover:system")
    assert replayed.code == 0, replayed.out


@pytest.mark.slow
def test_the_demo_records_and_replays_the_dog_then_its_suite(
    beatlog: Beatlog, tmp_path: Path
) -> None:
    run = beatlog("demo", "--duration", 0.5, "--out", tmp_path / "demo")

    log = tmp_path / "demo" / "dog.beatlog"
    assert run.code == 0, run.out
    assert f"PASS {log}" in run.out
    assert "22 DTCs recorded on the dog" in run.out
    assert "22 passed, 0 failed" in run.out
    assert f"The demo log is kept at {log}" in run.out
    with SessionLogReader(log) as reader:
        cycles = sum(1 for _ in reader.cycles())
        assert reader.header.system == "beatlog_examples.dog:system"
        assert reader.status.complete
        assert reader.end is not None
        assert reader.end.cycles == cycles > 0
        assert reader.end.robot_time_ns >= 500_000_000


# --help pages

SUBCOMMANDS = [
    "record",
    "replay",
    "test",
    "review",
    "approve",
    "show",
    "plot",
    "export",
    "import-bag",
    "demo",
    "help",
]


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
    for code in ("0 ", "1 ", "2 ", "130 "):
        assert f"\n  {code}" in page


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

    assert "as pytest's -k: words matched against names and tags" in page
    assert "given more than once, only DTCs with every tag given" in page


def test_the_top_level_help_ends_with_the_exit_codes(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["--help"])

    assert exited.value.code == 0
    assert capsys.readouterr().out.rstrip().endswith(EXIT_CODES.rstrip())


@pytest.mark.parametrize("topic", [[], ["test"], ["replay"]])
def test_help_prints_the_page_help_does(
    topic: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exited:
        main([*topic, "--help"])
    page = capsys.readouterr().out

    with pytest.raises(SystemExit) as helped:
        main(["help", *topic])

    assert (exited.value.code, helped.value.code) == (0, 0)
    assert capsys.readouterr().out == page


def test_help_of_an_unknown_command_is_one_line(beatlog: Beatlog) -> None:
    run = beatlog("help", "nope")

    assert_one_line_error(run, "argument COMMAND: invalid choice: 'nope'")


@pytest.mark.parametrize("command", [name for name in SUBCOMMANDS if name != "test"])
def test_verbose_says_what_it_does_for_the_command_at_hand(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    page = " ".join(help_page(command, capsys).split())

    assert "-v, --verbose also print the traceback of user code that failed to load" in page
    assert "summary" not in page.partition("--verbose")[2].partition(" -")[0]


def test_test_verbose_lists_every_dtc(capsys: pytest.CaptureFixture[str]) -> None:
    page = " ".join(help_page("test", capsys).split())

    assert (
        "-v, --verbose list every DTC in the summary, and print the traceback of user code "
        "that failed to load"
    ) in page


def test_review_help_says_it_asks_at_the_terminal(capsys: pytest.CaptureFixture[str]) -> None:
    page = " ".join(help_page("review", capsys).split())

    assert page.startswith(
        "usage: beatlog review [-h] [-v] [paths ...] Show each pending baseline change and "
        "ask at the terminal whether to accept, reject or skip it."
    )
