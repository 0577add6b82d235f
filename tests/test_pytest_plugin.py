"""The pytest plugin: *.dtc.toml files are collected as tests named after their spec;
its ``beatlog`` options re-baseline and audit them."""

from __future__ import annotations

import json
import os
import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

import beatlog_examples.rover
from beatlog.baseline.file import expected_path, pending_path, read_baseline
from beatlog.suite.discovery import discover_specs, select_specs
from beatlog.suite.spec import find_rootdir
from beatlog_examples.rover import record_lockstep
from tests.commands import at_a_terminal
from tests.conftest import Probe, RecordFn
from tests.factories import fill_the_disk_after, logged_counts
from tests.specs import FIRST_CHANGED_CYCLE, PROBE, ROVER, two_robots
from tests.systems import BUILT, leaks, leaky_system, quiet_system, record_session

COUNTED = "tests.systems:counted_system"


def spec_text(name: str, log: Path, system: str = "tests.conftest:probe_system") -> str:
    return (
        f'name = "{name}"\n'
        'purpose = "The probe stops near obstacles."\n'
        'procedure = ["Drive the probe towards a wall and back."]\n'
        f'log = "{log}"\n'
        f'system = "{system}"\n'
        'tags = ["probe"]\n'
    )


@pytest.fixture
def log(record_probe: RecordFn) -> Path:
    return record_probe(200)


def test_a_passing_dtc_is_one_passing_test_named_after_its_spec(
    pytester: pytest.Pytester, log: Path
) -> None:
    pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log))
    result = pytester.runpytest("-v")
    result.assert_outcomes(passed=1)
    result.stdout.fnmatch_lines(["*approach.dtc.toml::approach-wall PASSED*"])


def test_a_diverging_dtc_fails_with_its_first_divergence(
    pytester: pytest.Pytester, log: Path
) -> None:
    changed = "tests.conftest:probe_system_changed"
    pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log, changed))
    result = pytester.runpytest()
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(
        [
            "*first divergence: cycle 21, t = *state changes*",
            "*arbiter: 'dice' -> 'near'*",
            "reproduce: beatlog test *approach.dtc.toml",
        ]
    )
    result.stdout.no_fnmatch_line("*Traceback*")


def test_a_dtc_s_junit_properties_say_what_it_checked(pytester: pytest.Pytester, log: Path) -> None:
    pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log))

    pytester.runpytest("--junit-xml", "report.xml").assert_outcomes(passed=1)

    report = ET.parse(pytester.path / "report.xml").getroot()
    properties = {item.get("name"): item.get("value") for item in report.iter("property")}
    logged = logged_counts(log)
    assert properties == {
        "beatlog_verdict": "passed",
        "beatlog_spec": str(pytester.path / "approach.dtc.toml"),
        "beatlog_cycles": "200",
        "beatlog_state_changes": str(logged.state_changes),
        "beatlog_outputs": str(logged.outputs),
        "beatlog_draws": "40",
        "beatlog_samples": "0",
    }


def test_a_dtc_that_checks_nothing_is_an_error_unless_its_spec_intends_it(
    pytester: pytest.Pytester, tmp_path: Path
) -> None:
    quiet = record_session(tmp_path / "quiet.beatlog", quiet_system())
    system = "tests.systems:quiet_system"
    pytester.makefile(".dtc.toml", empty=spec_text("empty", quiet, system))
    pytester.makefile(
        ".dtc.toml", intended=spec_text("intended", quiet, system) + "allow_empty = true\n"
    )

    result = pytester.runpytest()

    result.assert_outcomes(passed=1, errors=1)
    result.stdout.fnmatch_lines(
        [
            "*_ ERROR at setup of dtc: empty _*",
            f"{quiet}: the replay checked nothing (20 cycles but no state change, output, *",
            "2 DTCs: 1 passed, 0 failed, 1 error",
        ]
    )


def test_a_dtc_that_cannot_run_is_an_error_and_one_that_can_builds_its_system_once(
    pytester: pytest.Pytester, log: Path
) -> None:
    pytester.makefile(".dtc.toml", broken=spec_text("broken", log, "tests.conftest:broken_probe"))
    pytester.makefile(".dtc.toml", counted=spec_text("counted", log, COUNTED))
    BUILT.clear()

    result = pytester.runpytest()

    result.assert_outcomes(passed=1, errors=1)
    result.stdout.fnmatch_lines(
        [
            "*_ ERROR at setup of dtc: broken _*",
            "'tests.conftest:broken_probe': the factory raised RuntimeError: the arena map is "
            "missing (line *",
            "2 DTCs: 1 passed, 0 failed, 1 error",
        ]
    )
    result.stdout.no_fnmatch_line("*Traceback*")
    assert BUILT == ["probe"]


def test_two_robots_of_one_repository_each_have_a_dtc_of_one_name(
    pytester: pytest.Pytester,
) -> None:
    specs = two_robots(pytester.path)
    options = ["-v", "--beatlog-coverage-json", "coverage.json", "--junit-xml", "report.xml"]

    result = pytester.runpytest(*options)

    result.assert_outcomes(passed=3)
    result.stdout.fnmatch_lines([f"{dtc} PASSED*" for dtc in specs])
    cases = ET.parse(pytester.path / "report.xml").getroot().iter("testcase")
    assert [(case.get("classname"), case.get("name")) for case in cases] == [
        ("probe.dtc.approach.dtc.toml", "approach"),
        ("probe.dtc.low-battery.dtc.toml", "low-battery"),
        ("rover.dtc.low-battery.dtc.toml", "low-battery"),
    ]
    document = json.loads((pytester.path / "coverage.json").read_text(encoding="utf-8"))
    assert document["dtcs"] == list(specs)
    assert list(document["systems"]) == [PROBE, ROVER]
    near = {system: document["systems"][system]["near"]["states"] for system in (PROBE, ROVER)}
    assert near[PROBE]['"near"']["dtcs"] == ["probe/dtc/approach.dtc.toml::approach"]
    assert near[ROVER]['"near"']["dtcs"] == ["rover/dtc/low-battery.dtc.toml::low-battery"]

    specs["probe/dtc/approach.dtc.toml::approach"].unlink()
    pytester.runpytest(*options).assert_outcomes(passed=2)

    document = json.loads((pytester.path / "coverage.json").read_text(encoding="utf-8"))
    assert document["systems"][PROBE]["near"]["no_longer_reached"] == [
        {"state": '"near"', "dtcs_before": ["probe/dtc/approach.dtc.toml::approach"]}
    ]
    assert document["systems"][ROVER]["near"]["no_longer_reached"] == []


def test_a_bad_spec_is_a_collection_error_naming_the_key(pytester: pytest.Pytester) -> None:
    pytester.makefile(".dtc.toml", broken='name = "x"\npurpose = "y"\n')
    result = pytester.runpytest()
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*broken.dtc.toml: missing keys 'procedure', 'log'"])
    result.stdout.no_fnmatch_line("*Traceback*")


def test_collection_can_be_turned_off(pytester: pytest.Pytester, log: Path) -> None:
    pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log))
    pytester.makeini("[pytest]\nbeatlog_collect = false\n")
    result = pytester.runpytest()
    assert result.ret == pytest.ExitCode.NO_TESTS_COLLECTED


def test_dtcs_are_selected_by_tag_and_marker(pytester: pytest.Pytester, log: Path) -> None:
    pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log))
    pytester.makepyfile(test_other="def test_other():\n    pass\n")
    pytester.runpytest("--strict-markers", "-m", "dtc", "-k", "probe").assert_outcomes(
        passed=1, deselected=1
    )


def test_the_fixture_replays_a_log_in_an_ordinary_test(
    pytester: pytest.Pytester, log: Path
) -> None:
    pytester.makepyfile(
        test_replays=f"""
        from tests.conftest import probe_system

        def test_passes(beatlog_replay):
            assert beatlog_replay({str(log)!r}, probe_system()).cycles == 200

        def test_diverges(beatlog_replay):
            beatlog_replay({str(log)!r}, probe_system(threshold=0.6))
        """
    )
    result = pytester.runpytest()
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines(["*first divergence: cycle 21*"])


def test_the_fixture_finds_a_relative_log_beside_the_test_file(
    pytester: pytest.Pytester, log: Path
) -> None:
    tests = pytester.mkdir("robot_tests")
    shutil.copy(log, tests / "approach.beatlog")
    (tests / "test_replays.py").write_text(
        "from tests.conftest import probe_system\n\n\n"
        "def test_passes(beatlog_replay):\n"
        "    assert beatlog_replay('approach.beatlog', probe_system()).cycles == 200\n"
    )

    result = pytester.runpytest("robot_tests")

    result.assert_outcomes(passed=1)


def test_the_fixture_fails_cleanly_naming_a_missing_log(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        test_replays="""
        from tests.conftest import probe_system

        def test_missing(beatlog_replay):
            beatlog_replay("gone.beatlog", probe_system())
        """
    )

    result = pytester.runpytest()

    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines([f"*{pytester.path / 'gone.beatlog'}: no such file*"])
    result.stdout.no_fnmatch_line("*reader.py*")
    result.stdout.no_fnmatch_line("*Traceback*")


@pytest.mark.slow
def test_dtcs_run_under_xdist_and_measure_behavior_coverage(
    pytester: pytest.Pytester, tmp_path: Path
) -> None:
    rover = "beatlog_examples.rover:system"
    for seed in range(3):
        log = tmp_path / f"rover-{seed}.beatlog"
        record_lockstep(log, duration_s=20.0, seed=seed)
        pytester.makefile(".dtc.toml", **{f"rover{seed}": spec_text(f"rover-{seed}", log, rover)})
    # The rover's folder, not its module name: coverage imports a module it is named and
    # then forgets it, and numpy (which the rover imports) cannot be imported twice.
    folder = Path(beatlog_examples.rover.__file__).parent
    result = pytester.runpytest_subprocess("-n", "2", f"--cov={folder}", "--cov-report=term")
    result.assert_outcomes(passed=3)
    result.stdout.fnmatch_lines(["*2 workers*", "*rover/behaviors.py*"])


def test_update_on_a_full_disk_is_one_line_naming_the_pending_file(
    pytester: pytest.Pytester, log: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    changed = "tests.conftest:probe_system_changed"
    spec = pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log, changed))
    monkeypatch.delenv("CI", raising=False)
    fill_the_disk_after(monkeypatch, files=0)

    result = pytester.runpytest("--beatlog-update", "-p", "no:cacheprovider")

    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines([f"*{pending_path(spec)}: cannot write: No space left on device"])
    result.stdout.no_fnmatch_line("*BaselineError*")  # one line, no traceback of beatlog's


def test_an_older_baseline_is_one_line_naming_the_command_that_upgrades_it(
    pytester: pytest.Pytester, log: Path
) -> None:
    spec = pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log))
    old = expected_path(spec)
    old.write_text(
        f"# beatlog expected departures from the recording, format 5\n"
        f"# log {log.name} sha256 {'0' * 64}\n",
        encoding="utf-8",
    )

    result = pytester.runpytest()

    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(
        [f"*{old}: a format 5 baseline: run 'beatlog upgrade-baselines {old}' to rewrite it*"]
    )
    result.stdout.no_fnmatch_line("*BaselineError*")


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_an_xdist_worker_s_dtcs_are_counted_and_covered_by_the_controller(
    pytester: pytest.Pytester, log: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Under pytest-xdist the DTCs run in a worker: their verdicts and the transition
    coverage of their logs are summed up by the controller, as in one process."""
    monkeypatch.setenv("PYTHONPATH", str(Path(__file__).parent.parent), prepend=os.pathsep)
    changed = "tests.conftest:probe_system_changed"
    pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log))
    pytester.makefile(".dtc.toml", changed=spec_text("changed", log, changed))

    result = pytester.runpytest("-n", "1", "--beatlog-coverage")

    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines(
        [
            "*1 worker*",
            "*= beatlog =*",
            "*transition coverage*",
            '*"far" → "near"*',
            "2 DTCs: 1 passed, 1 failed",
        ]
    )


def test_update_writes_the_pending_baseline_of_a_failing_dtc_but_never_in_ci(
    pytester: pytest.Pytester, log: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    changed = "tests.conftest:probe_system_changed"
    spec = pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log, changed))
    pytester.makefile(".dtc.toml", steady=spec_text("steady", log))
    orphan = pytester.makefile(".dtc.expected", gone="")

    pytester.runpytest().assert_outcomes(passed=1, failed=1)
    assert not pending_path(spec).exists()  # the safe default writes nothing

    monkeypatch.setenv("CI", "true")
    in_ci = pytester.runpytest("--beatlog-update")
    in_ci.assert_outcomes(passed=1, failed=1)
    in_ci.stdout.fnmatch_lines(["*= beatlog =*", "CI is set: no pending baselines written"])
    assert not pending_path(spec).exists()

    monkeypatch.delenv("CI")
    updated = pytester.runpytest("--beatlog-update")
    updated.assert_outcomes(passed=1, failed=1)
    updated.stdout.fnmatch_lines(
        [
            f"pending {pending_path(spec)} (0 state changes lost, 0 new, 8 moved, 8 output "
            "changes, open loop since cycle 21 (0.660 s), closed loop for 21 of 200 cycles "
            f"(10 %)): review with beatlog review {spec}, accept with beatlog approve {spec}",
            f"orphaned baseline {orphan}: no spec beside it; delete it",
            "2 DTCs: 1 passed, 1 failed",
        ]
    )
    pending = read_baseline(pending_path(spec)).whole
    assert (len(pending.changes), len(pending.outputs or ())) == (10, 8)
    assert not expected_path(spec).exists()
    pending_path(spec).replace(expected_path(spec))
    pytester.runpytest().stdout.fnmatch_lines(
        ["2 DTCs: 2 passed, 0 failed, 1 open loop (worth re-recording when convenient)"]
    )


def test_a_suite_past_its_open_loop_limits_fails_under_pytest_as_under_beatlog_test(
    pytester: pytest.Pytester, log: Path
) -> None:
    changed = "tests.conftest:probe_system_changed"
    spec = pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log, changed))
    pytester.makefile(".dtc.toml", steady=spec_text("steady", log))
    pytester.runpytest("--beatlog-update")
    pending_path(spec).replace(expected_path(spec))
    pyproject = pytester.path / "pyproject.toml"
    pyproject.write_text("[tool.beatlog]\nmax_open_loop_dtcs = 1\n", encoding="utf-8")
    assert pytester.runpytest().ret == pytest.ExitCode.OK

    pyproject.write_text("[tool.beatlog]\nmax_open_loop_share = 0.5\n", encoding="utf-8")
    stale = pytester.runpytest()

    stale.assert_outcomes(passed=2)
    assert stale.ret == pytest.ExitCode.TESTS_FAILED
    stale.stdout.fnmatch_lines(
        [
            "stale suite ([tool.beatlog]): 1 runs open loop for more than 50 % of its cycles "
            "(max_open_loop_share = 0.5)",
            "re-record first: approach-wall (90 % open loop)",
        ]
    )


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_audit_fails_a_dtc_whose_behaviors_leak_and_passes_a_sound_one(
    pytester: pytest.Pytester, log: Path, tmp_path: Path
) -> None:
    leaky_log = record_session(tmp_path / "leaky.beatlog", leaky_system())
    leaky = "tests.systems:leaky_system"
    pytester.makefile(".dtc.toml", leaky=spec_text("leaky", leaky_log, leaky))
    pytester.makefile(".dtc.toml", steady=spec_text("steady", log))

    pytester.runpytest().assert_outcomes(passed=2)  # the safe default audits nothing
    audited = pytester.runpytest("--beatlog-audit")

    audited.assert_outcomes(passed=1, failed=1)
    audited.stdout.fnmatch_lines(
        [
            "*AUDIT leaky*",
            *(f"*{call}*" for call, _ in leaks()),
            f"determinism audit: {len(leaks())} findings in 1 of 1 DTC",
        ]
    )
    audited.stdout.fnmatch_lines(["2 DTCs: 2 passed, 0 failed"])


@pytest.mark.parametrize(
    "workers",
    [pytest.param([], id="alone"), pytest.param(["-n", "2"], id="xdist", marks=pytest.mark.slow)],
)
@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_coverage_is_shown_and_written_at_the_end_of_the_session(
    pytester: pytest.Pytester,
    record_probe: RecordFn,
    workers: list[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    root = str(Path(__file__).parent.parent)  # for tests.conftest
    monkeypatch.setenv("PYTHONPATH", root, prepend=os.pathsep)
    pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", record_probe(200)))
    far = record_probe(40, name="far.beatlog", states=[Probe(distance=2.0)] * 40)
    pytester.makefile(".dtc.toml", steady=spec_text("steady", far))
    result = pytester.runpytest_subprocess(
        *workers, "--beatlog-coverage", "--beatlog-coverage-json", "coverage.json"
    )
    result.assert_outcomes(passed=2)
    result.stdout.fnmatch_lines(["*= beatlog =*", "*transition coverage*", '*"far" → "near"*'])
    document = json.loads((pytester.path / "coverage.json").read_text(encoding="utf-8"))
    assert document["dtcs"] == ["approach.dtc.toml::approach-wall", "steady.dtc.toml::steady"]
    assert document["systems"][PROBE]["near"]["no_longer_reached"] == []

    (pytester.path / "approach.dtc.toml").unlink()
    again = pytester.runpytest_subprocess(
        *workers, "--beatlog-coverage", "--beatlog-coverage-json", "coverage.json"
    )
    again.assert_outcomes(passed=1)
    again.stdout.fnmatch_lines(['*"near" (seen before in*'])
    document = json.loads((pytester.path / "coverage.json").read_text(encoding="utf-8"))
    assert document["systems"][PROBE]["near"]["no_longer_reached"] == [
        {"state": '"near"', "dtcs_before": ["approach.dtc.toml::approach-wall"]}
    ]


def test_without_the_option_no_coverage_is_shown(pytester: pytest.Pytester, log: Path) -> None:
    pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log))
    result = pytester.runpytest()
    result.assert_outcomes(passed=1)
    result.stdout.no_fnmatch_line("*transition coverage*")
    assert not (pytester.path / ".beatlog_cache").exists()


def test_break_at_stops_in_the_dtc_selected(
    pytester: pytest.Pytester, log: Path, breaks: list[dict[str, object]]
) -> None:
    pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log))
    pytester.makefile(".dtc.toml", leave=spec_text("leave-wall", log))

    result = pytester.runpytest("-k", "leave", "--beatlog-break-at", "12")

    result.assert_outcomes(passed=1, deselected=1)
    assert [stop["cycle"] for stop in breaks] == [12]


def test_break_at_refuses_a_run_that_selects_more_than_one_dtc(
    pytester: pytest.Pytester, log: Path, breaks: list[dict[str, object]]
) -> None:
    pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log))
    pytester.makefile(".dtc.toml", leave=spec_text("leave-wall", log))

    result = pytester.runpytest("--beatlog-break-at", "12")

    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines(["*--beatlog-break-at stops in one DTC, and 2 are selected*"])
    assert breaks == []


def test_break_at_past_the_end_of_the_dtcs_log_is_a_usage_error(
    pytester: pytest.Pytester, log: Path, breaks: list[dict[str, object]]
) -> None:
    pytester.makefile(".dtc.toml", leave=spec_text("leave-wall", log))

    result = pytester.runpytest("--beatlog-break-at", "200")

    assert result.ret == pytest.ExitCode.USAGE_ERROR
    assert result.stderr.lines == [
        f"ERROR: --beatlog-break-at 200: {log} has only 200 cycles; no break would be reached",
        "",
    ]
    assert breaks == []


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_quitting_the_debugger_ends_the_session_as_quitting_pytests_pdb_does(
    pytester: pytest.Pytester, log: Path
) -> None:
    pytester.makefile(".dtc.toml", leave=spec_text("leave-wall", log))
    environment = {key: value for key, value in os.environ.items() if key != "PYTHONBREAKPOINT"}
    command: list[str | Path] = [
        "-m",
        "pytest",
        "-p",
        "no:cacheprovider",
        pytester.path,
        "--beatlog-break-at",
        "12",
    ]

    with at_a_terminal(command, env=environment) as terminal:
        terminal.until("(Pdb) ")
        for _ in range(3):  # past the update and out of it: pytest's pdb still quits the run
            terminal.type("n", until="(Pdb) ")
        code, rest = terminal.end("q")

    assert code == pytest.ExitCode.INTERRUPTED
    *_, quitting, summary = rest.splitlines()
    assert re.fullmatch(r"!+ _pytest\.outcomes\.Exit: Quitting debugger !+", quitting)
    assert re.fullmatch(r"=+ no tests ran in \d+\.\d+s =+", summary), summary


def test_quitting_the_debugger_in_a_replay_of_the_fixture_ends_the_session(
    pytester: pytest.Pytester, log: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("PYTHONBREAKPOINT", "tests.conftest.quit_at_breakpoint")
    pytester.makepyfile(
        test_replays=f"""
        from tests.conftest import probe_system

        def test_stops(beatlog_replay):
            beatlog_replay({str(log)!r}, probe_system(), break_at=12)

        def test_never_runs():
            pass
        """
    )

    result = pytester.runpytest()

    assert result.ret == pytest.ExitCode.INTERRUPTED
    result.stdout.fnmatch_lines(["!* _pytest.outcomes.Exit: Quitting debugger !*"])
    result.assert_outcomes()


def test_break_on_divergence_stops_a_failing_dtc_at_its_first_divergence(
    pytester: pytest.Pytester, log: Path, breaks: list[dict[str, object]]
) -> None:
    changed = "tests.conftest:probe_system_changed"
    pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log))
    pytester.makefile(".dtc.toml", changed=spec_text("changed", log, changed))

    result = pytester.runpytest("--beatlog-break-on-divergence")

    result.assert_outcomes(passed=1, failed=1)
    assert [stop["cycle"] for stop in breaks] == [FIRST_CHANGED_CYCLE]


def test_break_points_refuse_xdist_workers(pytester: pytest.Pytester, log: Path) -> None:
    pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log))

    result = pytester.runpytest("-n", "2", "--beatlog-break-on-divergence")

    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines(["*run without pytest-xdist's -n (or with -n 0)*"])


PARITY_EXPRESSIONS = [
    "not box and dog",
    "dog",
    "suite",
    "dtc",
    "toml",
    "robots and not night",
    "rover or pat",
    "probe and not (box or rover)",
    "nothing",
]


@pytest.mark.parametrize("expression", PARITY_EXPRESSIONS)
def test_k_selects_the_dtcs_pytest_selects(
    pytester: pytest.Pytester, log: Path, expression: str
) -> None:
    (pytester.path / "pyproject.toml").write_text("[project]\nname = 'robots'\n")
    for folder, name in [
        ("robots/dog/suite", "avoid-box"),
        ("robots/dog/suite", "head-pat"),
        ("robots/dog/night", "wander"),
        ("robots/rover", "avoid-wall"),
        ("robots/rover", "dock-box"),
    ]:
        (pytester.path / folder).mkdir(parents=True, exist_ok=True)
        (pytester.path / folder / f"{name}.dtc.toml").write_text(spec_text(name, log))
    specs = discover_specs([pytester.path])

    selected = select_specs(specs, pattern=expression, rootdir=find_rootdir([pytester.path]))
    collected = pytester.runpytest("--collect-only", "-q", "-k", expression)

    ran = sorted(line.partition("::")[2] for line in collected.outlines if "::" in line)
    assert sorted(spec.name for spec in selected) == ran


NOISY = "\n[variants]\ncount = 2\nnoise = { distance = 0.05 }\n"
STARTED = 1_700_000_000_000_000_000
"""When the logs whose variants must fail were recorded: it keys their variants."""


def test_each_variant_a_dtc_declares_is_a_test_of_its_own(
    pytester: pytest.Pytester, log: Path
) -> None:
    pytester.makefile(".dtc.toml", approach=spec_text("approach-wall", log) + NOISY)

    result = pytester.runpytest("-v", "--beatlog-variants", "3")

    result.assert_outcomes(passed=4)
    result.stdout.fnmatch_lines(
        [
            "*approach.dtc.toml::approach-wall PASSED*",
            "*approach.dtc.toml::approach-wall[[]variant-1[]] PASSED*",
            "*approach.dtc.toml::approach-wall[[]variant-2[]] PASSED*",
            "*approach.dtc.toml::approach-wall[[]variant-3[]] PASSED*",
        ]
    )


def test_a_failing_variant_is_written_as_a_spec_the_next_session_runs(
    pytester: pytest.Pytester, record_probe: RecordFn
) -> None:
    log = record_probe(200, start_time_ns=STARTED)  # the same variants on every run
    fussy = spec_text("approach-wall", log, "tests.systems:fussy_system")
    pytester.makefile(".dtc.toml", approach=fussy + NOISY)

    first = pytester.runpytest()

    written = sorted(pytester.path.glob("approach.variant-*.dtc.toml"))
    assert written
    first.stdout.fnmatch_lines(
        [f"written: *{written[0].name} (a failing variant, now a DTC of its own: commit it)"]
    )
    failed = first.parseoutcomes()["failed"]
    again = pytester.runpytest("-v", "--beatlog-variants", "0", "-p", "no:cacheprovider")
    again.assert_outcomes(passed=1, failed=failed)
    number = written[0].name.split(".")[1]
    again.stdout.fnmatch_lines([f"*{written[0].name}::approach-wall-{number} FAILED*"])
