"""``beatlog test``: run a folder of DTC specs, exit 0/1/2, and say how to rerun a failure."""

from __future__ import annotations

import functools
import inspect
import json
import os
import re
import sys
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import pytest

from beatlog.suite.discovery import discover_specs
from tests.commands import (
    ROOT,
    Beatlog,
    Run,
    assert_error,
    at_a_terminal,
    failing_line,
    hide_matplotlib,
)
from tests.conftest import RecordFn, broken_probe
from tests.factories import vouch
from tests.specs import CHANGED, FIRST_CHANGED_CYCLE, PROBE, ROVER, two_robots, write_spec
from tests.systems import leaks, leaky_system, quiet_system, record_session
from tests.text import frames, suite_names, table_row, whole_lines

BeatlogTest = Callable[..., Run]

pytestmark = pytest.mark.usefixtures("wide_plain_console")


@pytest.fixture
def beatlog_test(beatlog: Beatlog) -> BeatlogTest:
    """``beatlog test -j 1 ARGS``: one worker unless a test asks for more (a pool costs ~0.5 s)."""
    return functools.partial(beatlog, "test")


@pytest.fixture
def log(record_probe: RecordFn) -> Path:
    return record_probe(300)


@pytest.fixture
def specs(tmp_path: Path) -> Path:
    return tmp_path / "specs"


def closing_line(run: Run) -> str:
    """The last line: the counts, the wall time and the cycles replayed."""
    return run.out.rstrip("\n").splitlines()[-1]


def assert_counts(run: Run, counts: str, cycles: int) -> None:
    assert re.fullmatch(rf"{counts} in \d+\.\d\d s \({cycles:,} cycles\)", closing_line(run)), (
        closing_line(run)
    )


def test_a_suite_that_replays_as_recorded_passes(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "avoid-pole", log)
    write_spec(specs / "night", "avoid-pole-at-night", log)

    run = beatlog_test(specs)

    assert run.code == 0
    assert run.err == ""
    assert run.out.startswith("DTC suite"), "no blank line where no progress bar was drawn"
    assert suite_names(run.out) == ["avoid-pole", "avoid-pole-at-night"]
    for name in ("avoid-pole", "avoid-pole-at-night"):
        assert table_row(run.out, name)[:4] == [name, "passed", "300", "9.0 s"]
    assert "reproduce:" not in run.out
    assert_counts(run, "2 passed, 0 failed", 600)


def test_a_spec_without_a_system_replays_against_the_one_its_project_vouches_for(
    beatlog_test: BeatlogTest, specs: Path, log: Path, record_probe: RecordFn
) -> None:
    write_spec(specs, "avoid-pole", log, system=None)
    write_spec(
        specs, "unnamed", record_probe(30, name="unnamed.beatlog", system_ref=""), system=None
    )
    hostile = record_probe(30, name="hostile.beatlog", system_ref="tempfile:mkdtemp")
    write_spec(specs, "hostile", hostile, system=None)
    vouch(specs, PROBE)

    run = beatlog_test(specs)

    assert run.code == 2
    assert table_row(run.out, "avoid-pole")[:4] == ["avoid-pole", "passed", "300", "9.0 s"]
    assert (
        f"note: avoid-pole: replayed against {PROBE}, which its log records and the project lists"
    ) in whole_lines(run.out)
    assert run.err == (
        f"beatlog: error: hostile ({specs / 'hostile.dtc.toml'}): "
        f"{specs / '..' / 'hostile.beatlog'}: records the system 'tempfile:mkdtemp', which this "
        "project does not vouch for; name it (--system, or system = in the spec) or list it "
        f"under [tool.beatlog] systems in {specs / 'pyproject.toml'}\n"
        f"beatlog: error: unnamed ({specs / 'unnamed.dtc.toml'}): "
        f"{specs / '..' / 'unnamed.beatlog'}: records no system; name one as module:factory "
        "(--system, or system = in the spec)\n"
    )


def test_a_diverging_dtc_fails_and_says_how_to_rerun_it(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "avoid-pole", log)
    earlier = write_spec(specs, "avoid-pole-earlier", log, CHANGED)

    run = beatlog_test(specs)

    assert run.code == 1
    assert run.err == ""
    assert f"DTC avoid-pole-earlier ({earlier})" in whole_lines(run.out)
    assert (
        f"first divergence: cycle {FIRST_CHANGED_CYCLE}, t = 0.660 s, state changes"
        in whole_lines(run.out)
    )
    assert "behavior state changes differ from the recording" in whole_lines(run.out)
    assert f"reproduce: beatlog test {earlier}" in whole_lines(run.out)
    assert re.search(
        rf"avoid-pole-earlier\s+│ failed .* cycle {FIRST_CHANGED_CYCLE}, state", run.out
    )
    assert_counts(run, "1 passed, 1 failed", 300 + FIRST_CHANGED_CYCLE + 1)


def test_the_rerun_command_runs_just_that_dtc(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "avoid-pole", log)
    earlier = write_spec(specs, "avoid-pole-earlier", log, CHANGED)
    rerun = re.search(r"reproduce: beatlog test (\S+)", beatlog_test(specs).out)
    assert rerun is not None

    run = beatlog_test(rerun.group(1))

    assert rerun.group(1) == str(earlier)
    assert run.code == 1
    assert_counts(run, "0 passed, 1 failed", FIRST_CHANGED_CYCLE + 1)


def test_a_dtc_that_cannot_run_is_an_error_exit_2(
    beatlog_test: BeatlogTest, specs: Path, log: Path, tmp_path: Path
) -> None:
    write_spec(specs, "avoid-pole", log)
    write_spec(specs, "avoid-pole-earlier", log, CHANGED)
    lost = write_spec(specs, "lost", tmp_path / "lost.beatlog")

    run = beatlog_test(specs)

    assert run.code == 2
    assert run.err == (
        f"beatlog: error: lost ({lost}): {lost.parent / '..' / 'lost.beatlog'}: no such file"
        " (a spec's log is relative to its folder)\n"
    )
    assert re.search(r"lost\s+│ error\s+│\s+— │ —", run.out)
    assert_counts(run, "1 passed, 1 failed, 1 error", 300 + FIRST_CHANGED_CYCLE + 1)


def test_a_system_that_fails_to_build_is_one_line_on_stderr_with_its_traceback_on_demand(
    beatlog_test: BeatlogTest, specs: Path, log: Path, tmp_path: Path
) -> None:
    write_spec(specs, "avoid-pole", log)
    broken = write_spec(specs, "broken", log, "tests.conftest:broken_probe")
    report = tmp_path / "dtc.xml"

    quiet = beatlog_test(specs)
    verbose = beatlog_test(specs, "--verbose", "--junit-xml", report)

    assert quiet.code == verbose.code == 2
    assert quiet.err == (
        f"beatlog: error: broken ({broken}): 'tests.conftest:broken_probe': the factory raised "
        f"RuntimeError: the arena map is missing ({failing_line(broken_probe)})\n"
    )
    assert verbose.err.startswith("Traceback (most recent call last):\n")
    assert 'raise RuntimeError("the arena map is missing")' in whole_lines(verbose.err)
    assert verbose.err.splitlines()[-1] == quiet.err.rstrip("\n")
    error = ET.parse(report).getroot().find("testcase[@name='broken']/error")
    assert error is not None
    assert error.text is not None
    assert (inspect.getsourcefile(broken_probe), "broken_probe") in frames(error.text)


def test_dash_k_runs_the_dtcs_whose_name_matches(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "avoid-pole", log)
    write_spec(specs, "avoid-wall", log)
    write_spec(specs, "dock", log, CHANGED)

    by_substring = beatlog_test(specs, "-k", "avoid")
    by_expression = beatlog_test(specs, "-k", "wall or dock")

    assert by_substring.code == 0
    assert_counts(by_substring, "2 passed, 0 failed", 600)
    assert suite_names(by_substring.out) == ["avoid-pole", "avoid-wall"]
    assert by_expression.code == 1
    assert_counts(by_expression, "1 passed, 1 failed", 300 + FIRST_CHANGED_CYCLE + 1)
    assert suite_names(by_expression.out) == ["avoid-wall", "dock"]


def test_dash_k_matches_tags_as_under_pytest(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "head-pat", log, tags=["touch"])
    write_spec(specs, "push-over", log)

    run = beatlog_test(specs, "-k", "touch")

    assert_counts(run, "1 passed, 0 failed", 300)
    assert table_row(run.out, "head-pat")[:4] == ["head-pat", "passed", "300", "9.0 s"]
    assert suite_names(run.out) == ["head-pat"]


def test_a_malformed_dash_k_is_one_line(beatlog_test: BeatlogTest, specs: Path, log: Path) -> None:
    write_spec(specs, "head-pat", log)

    run = beatlog_test(specs, "-k", "touch or")

    assert_error(run, "-k 'touch or': ends where a word was expected")


def test_tags_run_the_dtcs_that_carry_every_tag_given(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "avoid-pole", log, tags=["obstacles", "smoke"])
    write_spec(specs, "avoid-wall", log, CHANGED, tags=["obstacles"])
    write_spec(specs, "dock", log, tags=["smoke"])

    obstacles = beatlog_test(specs, "--tag", "obstacles")
    smoke_obstacles = beatlog_test(specs, "--tag", "smoke", "--tag", "obstacles")

    assert obstacles.code == 1
    assert_counts(obstacles, "1 passed, 1 failed", 300 + FIRST_CHANGED_CYCLE + 1)
    assert suite_names(obstacles.out) == ["avoid-pole", "avoid-wall"]
    assert smoke_obstacles.code == 0
    assert_counts(smoke_obstacles, "1 passed, 0 failed", 300)
    assert table_row(smoke_obstacles.out, "avoid-pole")[:4] == [
        "avoid-pole",
        "passed",
        "300",
        "9.0 s",
    ]


def test_fail_fast_stops_at_the_first_failure_and_counts_what_did_not_run(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "a-avoid-pole", log)
    write_spec(specs, "b-avoid-pole-earlier", log, CHANGED)
    write_spec(specs, "c-dock", log)
    write_spec(specs, "d-dock-earlier", log, CHANGED)

    run = beatlog_test(specs, "--fail-fast")

    assert run.code == 1
    assert f"DTC b-avoid-pole-earlier ({specs / 'b-avoid-pole-earlier.dtc.toml'})" in whole_lines(
        run.out
    )
    assert suite_names(run.out) == ["a-avoid-pole", "b-avoid-pole-earlier"]
    assert_counts(run, "1 passed, 1 failed, 2 not run", 300 + FIRST_CHANGED_CYCLE + 1)


@pytest.mark.parametrize("option", ["-x", "--exitfirst"])
def test_dash_x_stops_after_the_first_failure_as_pytest_does(
    beatlog_test: BeatlogTest, specs: Path, log: Path, option: str
) -> None:
    write_spec(specs, "a-avoid-pole-earlier", log, CHANGED)
    write_spec(specs, "b-dock-earlier", log, CHANGED)

    run = beatlog_test(specs, option)

    assert run.code == 1
    assert suite_names(run.out) == ["a-avoid-pole-earlier"]
    assert_counts(run, "0 passed, 1 failed, 1 not run", FIRST_CHANGED_CYCLE + 1)


def test_dash_x_with_workers_stops_submitting_after_the_first_failure(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    for name in ("a", "b", "c", "d", "e", "f"):
        write_spec(specs, f"{name}-earlier", log, CHANGED)

    run = beatlog_test(specs, "-x", "-j", "2")

    assert run.code == 1
    assert closing_line(run).startswith("0 passed, ")
    assert "not run" in closing_line(run), "the rest are neither started nor waited for"


def test_lf_reruns_only_the_dtcs_that_failed_last_time(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "avoid-pole", log)
    write_spec(specs, "avoid-pole-earlier", log, CHANGED)
    write_spec(specs, "dock", log)
    assert beatlog_test(specs).code == 1

    rerun = beatlog_test(specs, "--lf")

    assert rerun.code == 1
    assert "--lf: rerunning the 1 DTC that failed last time" in whole_lines(rerun.out)
    assert suite_names(rerun.out) == ["avoid-pole-earlier"]
    assert_counts(rerun, "0 passed, 1 failed", FIRST_CHANGED_CYCLE + 1)


def test_lf_runs_everything_when_nothing_failed_last_time(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "avoid-pole", log)
    write_spec(specs, "dock", log)
    assert beatlog_test(specs).code == 0

    rerun = beatlog_test(specs, "--last-failed")

    assert rerun.code == 0
    assert "--lf: no DTC selected failed last time; running all 2" in whole_lines(rerun.out)
    assert suite_names(rerun.out) == ["avoid-pole", "dock"]


def test_lf_forgets_a_failure_once_it_passes_and_keeps_those_not_run(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "avoid-pole", log, CHANGED)
    write_spec(specs, "dock", log, CHANGED)
    assert beatlog_test(specs).code == 1
    write_spec(specs, "avoid-pole", log)
    assert beatlog_test(specs, "--lf", "-k", "avoid").code == 0

    rerun = beatlog_test(specs, "--lf")

    assert suite_names(rerun.out) == ["dock"]


def test_junit_xml_reports_every_dtc_for_ci(
    beatlog_test: BeatlogTest, specs: Path, log: Path, tmp_path: Path
) -> None:
    write_spec(specs, "avoid-pole", log)
    wall = write_spec(specs, "avoid-wall", log, CHANGED)
    report = tmp_path / "reports" / "dtc.xml"

    run = beatlog_test(specs, "--junit-xml", report)

    assert run.code == 1
    suite = ET.parse(report).getroot()
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors")) == ("2", "1", "0")
    cases = suite.findall("testcase")
    assert [case.get("name") for case in cases] == ["avoid-pole", "avoid-wall"]
    failure = cases[1].find("failure")
    assert failure is not None
    assert failure.get("message") == "behavior state changes differ from the recording"
    assert failure.text is not None
    lines = whole_lines(failure.text)
    assert lines[0] == f"DTC avoid-wall ({wall})"
    assert lines[2] == f"first divergence: cycle {FIRST_CHANGED_CYCLE}, t = 0.660 s, state changes"
    assert lines[-1] == f"reproduce: beatlog test {wall}"
    assert "\x1b[" not in failure.text  # no terminal colors in a CI report


@pytest.mark.parametrize("jobs", ["1", "2"], ids=["in-process", "workers"])
def test_html_reports_every_dtc_with_its_charts(
    beatlog_test: BeatlogTest, specs: Path, log: Path, tmp_path: Path, jobs: str
) -> None:
    write_spec(specs, "avoid-pole", log)
    earlier = write_spec(specs, "avoid-pole-earlier", log, CHANGED)
    report = tmp_path / "reports" / "dtc.html"
    report.parent.mkdir()

    run = beatlog_test(specs, "--html", report, "-j", jobs)

    assert run.code == 1
    assert run.err == ""
    page = report.read_text(encoding="utf-8")
    lines = whole_lines(page)
    assert "<title>beatlog DTC report: 1 passed, 1 failed</title>" in lines
    assert (
        f"<h3>First divergence: cycle {FIRST_CHANGED_CYCLE}, t = 0.660 s — state changes</h3>"
        in lines
    )
    assert (
        f'<p class="rerun">Rerun just this DTC: <code>beatlog test {earlier}</code></p></div>'
        in lines
    )
    assert page.count("<svg") == 3  # a pass: the session; a failure: a close-up and the session


@pytest.mark.parametrize("option", ["--html", "--junit-xml", "--coverage-json"])
def test_a_report_is_written_into_a_folder_made_for_it(
    beatlog_test: BeatlogTest, specs: Path, log: Path, tmp_path: Path, option: str
) -> None:
    write_spec(specs, "avoid-pole", log)
    report = tmp_path / "reports" / "today" / "dtc.out"

    run = beatlog_test(specs, option, report)

    assert run.code == 0, run.err
    assert report.stat().st_size > 0


@pytest.mark.parametrize("option", ["--html", "--junit-xml", "--coverage-json"])
def test_a_report_that_cannot_be_written_is_refused_before_the_suite_runs(
    beatlog_test: BeatlogTest, specs: Path, log: Path, tmp_path: Path, option: str
) -> None:
    write_spec(specs, "avoid-pole", log)
    (tmp_path / "notes").write_text("a file where a folder goes")
    report = tmp_path / "notes" / "dtc.out"

    run = beatlog_test(specs, option, report)

    assert run.code == 2
    assert run.out == ""  # nothing replayed
    assert run.err == f"beatlog: error: {report}: {report.parent} is not a directory\n"


def test_a_report_where_a_folder_is_is_refused(
    beatlog_test: BeatlogTest, specs: Path, log: Path, tmp_path: Path
) -> None:
    write_spec(specs, "avoid-pole", log)

    run = beatlog_test(specs, "--html", tmp_path)

    assert run.code == 2
    assert run.err == f"beatlog: error: {tmp_path}: is a directory\n"


def test_the_html_report_draws_its_charts_without_matplotlib(
    beatlog_test: BeatlogTest,
    specs: Path,
    log: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    write_spec(specs, "avoid-pole", log)
    hide_matplotlib(monkeypatch)
    report = tmp_path / "dtc.html"

    run = beatlog_test(specs, "--html", report)

    assert run.code == 0, run.err
    assert report.read_text(encoding="utf-8").count("<svg") == 1


def test_worker_processes_give_the_same_verdicts(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "avoid-pole", log)
    earlier = write_spec(specs, "avoid-pole-earlier", log, CHANGED)
    write_spec(specs, "dock", log)

    run = beatlog_test(specs, "-j", "2")

    assert run.code == 1
    assert f"reproduce: beatlog test {earlier}" in whole_lines(run.out)
    assert_counts(run, "2 passed, 1 failed", 600 + FIRST_CHANGED_CYCLE + 1)


def test_the_current_folder_is_searched_by_default(
    beatlog_test: BeatlogTest,
    specs: Path,
    log: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    write_spec(specs, "avoid-pole", log)
    monkeypatch.chdir(specs.parent)
    monkeypatch.setattr(sys, "path", list(sys.path))  # main() adds the working folder

    run = beatlog_test()

    assert run.code == 0
    assert_counts(run, "1 passed, 0 failed", 300)


def rows(out: str, title: str) -> list[list[str]]:
    """The cells of each row of the table ``title`` printed, on a console wide enough
    for each row to keep to one line."""
    lines = out.splitlines()
    table = lines[lines.index(title) + 1 :]
    body = table[next(n for n, line in enumerate(table) if line.startswith("┡")) + 1 :]
    ended = next(n for n, line in enumerate(body) if line.startswith("└"))
    return [[cell.strip() for cell in line.strip("│").split("│")] for line in body[:ended]]


def test_two_robots_of_one_repository_each_have_a_dtc_of_one_name(
    beatlog_test: BeatlogTest, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "400")
    specs = two_robots(tmp_path)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))  # main() adds the working folder
    coverage, junit = tmp_path / "coverage.json", tmp_path / "dtc.xml"
    probe_ids = list(specs)[:2]
    rover_id = list(specs)[2]

    run = beatlog_test("--coverage", "--coverage-json", coverage, "--junit-xml", junit)

    assert (run.code, run.err) == (0, "")
    assert [row[0] for row in rows(run.out, "DTC suite")] == ["approach", *probe_ids[1:], rover_id]
    assert_counts(run, "3 passed, 0 failed", 440)
    cases = ET.parse(junit).getroot().findall("testcase")
    assert [(case.get("classname"), case.get("name")) for case in cases] == [
        ("probe/dtc", "approach"),
        ("probe/dtc", "probe/dtc/low-battery.dtc.toml::low-battery"),
        ("rover/dtc", "rover/dtc/low-battery.dtc.toml::low-battery"),
    ]
    assert [row[:2] for row in rows(run.out, "transition coverage")] == [
        [PROBE, "arbiter"],
        [PROBE, "near"],
        [PROBE, "dice"],
        [ROVER, "arbiter"],
        [ROVER, "near"],
        [ROVER, "dice"],
    ]
    document = json.loads(coverage.read_text(encoding="utf-8"))
    assert document["dtcs"] == list(specs)
    near = {system: document["systems"][system]["near"]["states"] for system in (PROBE, ROVER)}
    assert near[PROBE]['"near"']["dtcs"] == ["probe/dtc/approach.dtc.toml::approach"]
    assert near[PROBE]['"far"']["dtcs"] == probe_ids
    assert near[ROVER]['"near"']["dtcs"] == near[ROVER]['"far"']["dtcs"] == [rover_id]

    specs["probe/dtc/approach.dtc.toml::approach"].unlink()
    again = beatlog_test("--coverage", "--coverage-json", coverage)

    assert (again.code, again.err) == (0, "")
    assert [row[1:] for row in rows(again.out, "transition coverage") if row[1] == "near"] == [
        ["near", '"far" (1 DTC, 40 cycles)', "none", '"near" (seen before in approach)'],
        [
            "near",
            '"far" (1 DTC, 102 cycles), "near" (1 DTC, 98 cycles)',
            '"far" → "near" ×2 in 1 DTC; "near" → "far" ×2 in 1 DTC',
            "",
        ],
    ]
    document = json.loads(coverage.read_text(encoding="utf-8"))
    assert document["systems"][PROBE]["near"]["no_longer_reached"] == [
        {"state": '"near"', "dtcs_before": ["probe/dtc/approach.dtc.toml::approach"]}
    ]
    assert document["systems"][ROVER]["near"]["no_longer_reached"] == []


@pytest.mark.slow
def test_beatlog_test_at_this_repository_s_root_runs_every_example_suite(
    beatlog_test: BeatlogTest, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "400")
    monkeypatch.chdir(ROOT)
    monkeypatch.setattr(sys, "path", list(sys.path))  # main() adds the working folder
    found = discover_specs([Path()])

    run = beatlog_test("--verbose")

    assert (run.code, run.err) == (0, "")
    shown = [row[0] for row in rows(run.out, "DTC suite")]
    assert len(shown) == len(found) > 2
    assert [label for label in shown if "::" in label] == [
        "examples/src/beatlog_examples/dog/suite/low-battery.dtc.toml::low-battery",
        "examples/src/beatlog_examples/trees/suite/low-battery.dtc.toml::low-battery",
    ]
    assert closing_line(run).startswith(f"{len(found)} passed, 0 failed in ")


# bad input: exit 2 and one line on stderr


def test_a_folder_without_specs_is_a_usage_error(beatlog_test: BeatlogTest, specs: Path) -> None:
    specs.mkdir()

    run = beatlog_test(specs)

    assert_error(run, f"no DTC specs to run in {specs} (looked for *.dtc.toml)")


def test_a_selection_that_matches_nothing_exits_5_as_pytest_does(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "avoid-pole", log)

    by_name = beatlog_test(specs, "-k", "dock")
    by_tag = beatlog_test(specs, "--tag", "night")

    for run in (by_name, by_tag):
        assert run == (
            5,
            "",
            f"beatlog: error: none of the 1 DTC specs in {specs} match -k/--tag\n",
        )


def test_a_bad_spec_is_one_line_naming_the_file_and_key(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "avoid-pole", log)
    bad = write_spec(specs, "dock", log, tags="docking")

    run = beatlog_test(specs)

    assert_error(run, f"{bad}: key 'tags': expected a list, got a string")


def test_a_path_that_does_not_exist_is_one_line(beatlog_test: BeatlogTest, tmp_path: Path) -> None:
    run = beatlog_test(tmp_path / "nowhere")

    assert_error(run, f"{tmp_path / 'nowhere'}: no such file or folder")


@pytest.mark.parametrize(
    ("jobs", "problem"),
    [
        ("0", "must be positive: '0' (see 'beatlog test --help')"),
        ("x", "not a whole number: 'x' (see 'beatlog test --help')"),
    ],
)
def test_jobs_must_be_a_positive_whole_number(
    beatlog_test: BeatlogTest, specs: Path, log: Path, jobs: str, problem: str
) -> None:
    write_spec(specs, "avoid-pole", log)

    run = beatlog_test(specs, "-j", jobs)

    assert_error(run, f"argument -j/--jobs: {problem}")


# --audit: the determinism audit


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_audit_names_every_leak_and_fails_the_run(
    beatlog_test: BeatlogTest, specs: Path, log: Path, tmp_path: Path
) -> None:
    leaky_log = record_session(tmp_path / "leaky.beatlog", leaky_system())
    leaky = write_spec(specs, "leaky", leaky_log, "tests.systems:leaky_system")
    write_spec(specs, "avoid-pole", log)
    report = tmp_path / "dtc.xml"

    unaudited = beatlog_test(specs)
    run = beatlog_test(specs, "--audit", "--junit-xml", report)

    assert unaudited.code == 0
    assert "determinism audit" not in unaudited.out
    assert run.code == 1
    assert run.err == ""
    audits = [line for line in whole_lines(run.out) if line.startswith("AUDIT ")]
    assert audits == [f"AUDIT leaky ({leaky})"]  # avoid-pole's audit found nothing
    for call, site in leaks():
        assert re.search(rf"{re.escape(call)}\s+│ {re.escape(site)}\s+│\s+20 │", run.out), call
    assert f"determinism audit: {len(leaks())} findings in 1 of 2 DTCs" in whole_lines(run.out)
    assert_counts(run, "2 passed, 0 failed", 320)
    (failure,) = ET.parse(report).getroot().findall("testcase/failure")
    assert failure.get("message") == f"determinism audit: {len(leaks())} findings"


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_audit_of_a_sound_suite_passes(beatlog_test: BeatlogTest, specs: Path, log: Path) -> None:
    write_spec(specs, "avoid-pole", log)

    run = beatlog_test(specs, "--audit")

    assert run.code == 0
    assert (
        "determinism audit: no findings in 1 DTC (each replayed with PYTHONHASHSEED=1 and 2)"
        in whole_lines(run.out)
    )
    assert_counts(run, "1 passed, 0 failed", 300)


def test_a_long_suite_lists_what_did_not_pass_and_every_dtc_with_verbose(
    beatlog_test: BeatlogTest, specs: Path, record_probe: RecordFn
) -> None:
    short = record_probe(20)
    for n in range(33):
        write_spec(specs, f"lap-{n:02}", short)
    write_spec(specs, "lap-changed", short, "tests.systems:probe_system_greedy")

    brief = beatlog_test(specs)
    verbose = beatlog_test(specs, "--verbose")

    assert brief.code == verbose.code == 1
    failed = table_row(brief.out, "lap-changed")
    del failed[4]  # its wall time
    assert failed == ["lap-changed", "failed", "1", "0.0 s", "cycle 0, extra random draw"]
    assert table_row(brief.out, "lap-00") == []
    assert "… and 33 passed, not listed: run with --verbose to list every DTC" in whole_lines(
        brief.out
    )
    assert [table_row(verbose.out, f"lap-{n:02}")[:4] for n in range(33)] == [
        [f"lap-{n:02}", "passed", "20", "0.6 s"] for n in range(33)
    ]
    assert "not listed" not in verbose.out


def test_verbose_says_what_each_passing_dtc_checked(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "avoid-pole", log)

    run = beatlog_test(specs, "--verbose")

    assert run.code == 0
    assert run.out.splitlines()[0] == (
        "PASS avoid-pole: 300 cycles, 45 state changes, 453 outputs, 60 draws checked"
    )


def test_a_dtc_that_checks_nothing_is_an_error_unless_its_spec_intends_it(
    beatlog_test: BeatlogTest, specs: Path, tmp_path: Path
) -> None:
    quiet = record_session(tmp_path / "quiet.beatlog", quiet_system())
    write_spec(specs, "empty", quiet, "tests.systems:quiet_system")
    write_spec(specs, "intended", quiet, "tests.systems:quiet_system", allow_empty=True)

    run = beatlog_test(specs, "--verbose")

    assert run.code == 2
    assert run.err == (
        f"beatlog: error: empty ({specs / 'empty.dtc.toml'}): {specs / '..' / quiet.name}: "
        "the replay checked "
        "nothing (20 cycles but no state change, output, draw or sample); if nothing is "
        "meant to happen in it, accept it with --allow-empty (in a spec: allow_empty = "
        "true)\n"
    )
    assert "PASS intended: 20 cycles checked (allowed empty)" in whole_lines(run.out)
    assert_counts(run, "1 passed, 0 failed, 1 error", 20)


def test_break_at_stops_in_the_one_dtc_selected(
    beatlog_test: BeatlogTest, specs: Path, log: Path, breaks: list[dict[str, object]]
) -> None:
    write_spec(specs, "approach", log)
    write_spec(specs, "leave", log)

    run = beatlog_test(specs, "-k", "leave", "--break-at", "12")

    assert run.code == 0
    assert [stop["cycle"] for stop in breaks] == [12]


def test_break_at_with_more_than_one_dtc_selected_is_a_usage_error(
    beatlog_test: BeatlogTest, specs: Path, log: Path, breaks: list[dict[str, object]]
) -> None:
    write_spec(specs, "approach", log)
    write_spec(specs, "leave", log)

    run = beatlog_test(specs, "--break-at", "12")

    assert_error(
        run, "--break-at stops in one DTC, and 2 are selected: name its spec or select it with -k"
    )
    assert breaks == []


def test_break_at_past_the_end_of_the_dtcs_log_is_a_usage_error(
    beatlog_test: BeatlogTest, specs: Path, log: Path, breaks: list[dict[str, object]]
) -> None:
    write_spec(specs, "leave", log)

    run = beatlog_test(specs, "--break-at", "300")

    assert run.err == (
        f"beatlog: error: --break-at 300: {specs / '..' / log.name} has only 300 cycles; "
        "no break would be reached\n"
    )
    assert (run.code, run.out, breaks) == (2, "", [])


def test_quitting_the_debugger_stops_the_run_cleanly(specs: Path, log: Path) -> None:
    write_spec(specs, "leave", log)
    environment = {key: value for key, value in os.environ.items() if key != "PYTHONBREAKPOINT"}
    command: list[str | Path] = ["-m", "beatlog.cli.main", "test", specs, "--break-at", "12"]

    with at_a_terminal(command, env=environment) as terminal:
        terminal.until("(Pdb) ")
        code, rest = terminal.end("q")

    assert code == 130
    assert re.fullmatch(
        r"q\n0 passed, 0 failed, 1 not run in \d+\.\d\d s \(0 cycles\)\n"
        r"beatlog: stopped in the debugger\n",
        rest,
    ), rest


def test_break_on_divergence_stops_each_failing_dtc_at_its_first_divergence(
    beatlog_test: BeatlogTest, specs: Path, log: Path, breaks: list[dict[str, object]]
) -> None:
    write_spec(specs, "as-recorded", log)
    write_spec(specs, "changed", log, CHANGED)

    run = beatlog_test(specs, "--break-on-divergence", "-j", "2")

    assert run.code == 1
    assert [stop["cycle"] for stop in breaks] == [FIRST_CHANGED_CYCLE]


VARIANTS = {"noise": {"distance": 0.05}}
STARTED = 1_700_000_000_000_000_000
"""When the logs whose variants must fail were recorded: it keys their variants."""


def test_variants_run_as_dtcs_and_a_failing_one_is_written_as_a_spec_that_fails_again(
    beatlog_test: BeatlogTest, specs: Path, record_probe: RecordFn
) -> None:
    log = record_probe(100, start_time_ns=STARTED)
    write_spec(specs, "dock", log, "tests.systems:fussy_system", variants=VARIANTS)

    run = beatlog_test("--variants", "4", specs)

    written = sorted(specs.glob("dock.variant-*.dtc.toml"))
    assert run.code == 1
    assert written
    for path in written:
        assert f"written: {path} (a failing variant, now a DTC of its own: commit it)" in (
            whole_lines(run.out)
        )
        assert f"reproduce: beatlog test {path}" in whole_lines(run.out)
    assert re.search(r"dock\[variant-\d\]\s+│ failed .* exception", run.out)
    again = beatlog_test(written[0])
    assert again.code == 1
    assert "near raised ValueError: a negative distance" in again.out
    assert "written:" not in again.out


def test_passing_variants_are_counted_not_listed(
    beatlog_test: BeatlogTest, specs: Path, log: Path
) -> None:
    write_spec(specs, "dock", log, variants={**VARIANTS, "count": 8})

    run = beatlog_test(specs)

    assert run.code == 0
    assert "dock[variant-" not in run.out
    assert "… and 8 passed (8 of them variants), not listed" in run.out
    assert_counts(run, "9 passed, 0 failed", 9 * 300)
    assert list(specs.glob("*.variant-*")) == []


def test_update_leaves_variants_alone(beatlog_test: BeatlogTest, specs: Path, log: Path) -> None:
    write_spec(specs, "dock", log, CHANGED, variants={**VARIANTS, "count": 2})

    run = beatlog_test("--update", specs)

    assert run.code == 1
    written = sorted(path.name for path in specs.glob("dock*"))
    assert written == ["dock.dtc.pending", "dock.dtc.toml"]
    assert_counts(run, "2 passed, 1 failed", FIRST_CHANGED_CYCLE + 1 + 2 * 300)


def test_a_negative_number_of_variants_is_a_usage_error(
    beatlog_test: BeatlogTest, specs: Path
) -> None:
    run = beatlog_test("--variants", "-1", specs)

    assert run.code == 2
    assert "--variants: must be 0 or more: '-1'" in run.err
