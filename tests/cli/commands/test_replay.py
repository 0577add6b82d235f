"""``beatlog replay``: a verdict as the exit code, the first divergence and how to
reproduce it, as text or JSON; a log never chooses the code it replays."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from beatlog.log.reader import SessionLogReader
from beatlog.model.random import RecordingRandom
from beatlog.record.recorder import Recorder
from tests.commands import Beatlog, assert_error, replay_line
from tests.conftest import RecordFn, distances, first_cycle_below
from tests.factories import cut_in_half, vouch
from tests.specs import CHANGED, FIRST_CHANGED_CYCLE, PROBE, PROBE_CHECKED
from tests.systems import quiet_system, record_scatter
from tests.text import whole_lines

pytestmark = pytest.mark.usefixtures("wide_plain_console")


def test_replay_passes_a_log_against_the_system_that_recorded_it(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    log = record_probe(300)

    run = beatlog("replay", log, "--system", PROBE)

    assert run.code == 0
    assert re.fullmatch(replay_line("PASS", log, PROBE_CHECKED) + "\n", run.out), run.out
    assert run.err == ""


def test_a_misspelt_project_key_is_named_instead_of_refusing_the_log(
    beatlog: Beatlog, record_probe: RecordFn, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "pyproject.toml").write_text(
        f'[tool.beatlog]\nsystem = ["{PROBE}"]\n', encoding="utf-8"
    )
    monkeypatch.chdir(tmp_path)
    log = record_probe(30)

    run = beatlog("replay", log)

    assert_error(
        run,
        f"{tmp_path / 'pyproject.toml'}: unknown key 'tool.beatlog.system' "
        "(did you mean 'tool.beatlog.systems'?)",
    )


def test_replay_without_a_system_uses_and_names_the_one_the_project_vouches_for(
    beatlog: Beatlog, record_probe: RecordFn, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_probe(300)
    vouch(tmp_path, PROBE)
    monkeypatch.chdir(tmp_path)

    run = beatlog("replay", log)

    assert run.code == 0
    assert re.fullmatch(replay_line("PASS", log, PROBE_CHECKED) + "\n", run.out), run.out
    assert run.err == (
        f"beatlog: replaying against {PROBE}, as recorded in {log} "
        "and listed in the project's [tool.beatlog] systems\n"
    )


def test_replay_without_a_system_of_a_log_that_records_none_is_one_line(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    log = record_probe(30, system_ref="")

    run = beatlog("replay", log)

    assert_error(
        run,
        f"{log}: records no system; name one as module:factory (--system, or system = in the spec)",
    )


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

    assert_error(
        run,
        f"{log}: records the system {recorded!r}, which this project does not vouch for; "
        "name it (--system, or system = in the spec) or list it under [tool.beatlog] systems "
        f"in {tmp_path / 'pyproject.toml'}",
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
    first = run.out.splitlines()[0]
    assert re.fullmatch(replay_line("FAIL", log, "22 cycles, 0.7 s robot time"), first), first
    assert (
        f"first divergence: cycle {FIRST_CHANGED_CYCLE}, t = 0.660 s, state changes"
        in whole_lines(run.out)
    )
    assert "behavior state changes differ from the recording" in whole_lines(run.out)
    assert f"reproduce: beatlog replay {log} --system {CHANGED}" in whole_lines(run.out)
    assert run.err == ""


def test_replay_judges_a_window_of_cycles_alone(beatlog: Beatlog, record_probe: RecordFn) -> None:
    log = record_probe(300)

    run = beatlog("replay", log, "--system", CHANGED, "--start-cycle", "30", "--end-cycle", "60")

    assert run.code == 0, run
    first = run.out.splitlines()[0]
    assert first.startswith(f"PASS {log}  31 cycles, "), first
    assert "log complete" not in first  # its end was not read


def test_replay_starts_a_window_fresh_where_asked(beatlog: Beatlog, record_probe: RecordFn) -> None:
    log = record_probe(300)
    cycle = first_cycle_below(0.3) + 100
    window = ("--start-cycle", str(cycle), "--end-cycle", str(cycle + 5), "--fresh-start")

    run = beatlog("replay", log, "--system", "tests.systems:fragile_system", *window)

    assert run.code == 1, run
    assert f"cycle {cycle}" in run.out
    assert "dice raised ZeroDivisionError: fragile dice" in whole_lines(run.out)
    assert (
        f"note: fresh start: the behaviors start from rest at cycle {cycle}; "
        f"{cycle} cycles before it not replayed"
    ) in whole_lines(run.out)
    assert run.out.rstrip().endswith(" ".join(window))  # the reproduce command


def test_a_window_that_starts_after_it_ends_is_one_line(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    run = beatlog("replay", record_probe(30), "--start-cycle", "9", "--end-cycle", "8")

    assert_error(run, "--start-cycle 9 is after --end-cycle 8")


def test_replay_maps_robot_state_fields_renamed_or_retyped_since_the_recording(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    log = record_probe(300)
    renamed = ("--system", "tests.systems:probe_system_ranged")
    retyped = ("--system", "tests.systems:probe_system_centimetred")

    assert beatlog("replay", log, *renamed, "--rename-field", "distance=range").code == 0
    converted = ("--convert-field", "distance=tests.systems:centimetres")
    assert beatlog("replay", log, *retyped, *converted).code == 0
    assert_error(
        beatlog("replay", log, *renamed),
        f"{log}: recorded with robot state tests.conftest.Probe, which does not fit the "
        "system's tests.systems.Ranged: Probe is not Ranged (a robot state type renamed since "
        "keeps exactly its fields); field 'distance' is gone; the system has 'range' (number) "
        'in its place: if renamed, add field_renames = { distance = "range" } to the spec '
        "(beatlog replay: --rename-field distance=range)",
    )
    assert_error(
        beatlog("replay", log, *renamed, "--rename-field", "distance"),
        "argument --rename-field: expected NAME=VALUE: 'distance' (see 'beatlog replay --help')",
    )
    failing = ("--convert-field", "distance=tests.systems:centimetres_unless_close")
    assert_error(
        beatlog("replay", log, *retyped, *failing),
        f"{log}: robot state of cycle 46: field 'distance': "
        "tests.systems:centimetres_unless_close raised ValueError: 0.08 m is too close to "
        "convert",
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
    assert result["checked"] == {"state_changes": 45, "outputs": 453, "draws": 60, "samples": 0}


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
    assert f"first divergence: cycle {kept}, t = 6.450 s, log ended" in whole_lines(failed.out)
    advice = " ".join(whole_lines(failed.out)[2:-2])  # the panel's text, however wrapped
    assert re.fullmatch(
        rf"the log ends early \(truncated at cycle {kept}: the last record is cut off at byte "
        r"\d+\); if the session ended there \(a crash\), accept what it holds with "
        r"--allow-truncated \(in a spec: allow_truncated = true\)",
        advice,
    ), advice
    assert allowed.code == 0
    assert re.fullmatch(
        rf"PASS {re.escape(str(log))}  {kept} cycles, \d+ state changes, \d+ outputs, "
        r"\d+ draws checked; 6\.5 s robot time in [^;]+; "
        rf"log truncated at cycle {kept}: the last record is cut off at byte \d+\n",
        allowed.out,
    ), allowed.out


def test_a_replay_that_checks_nothing_is_bad_input_unless_allowed(
    beatlog: Beatlog, tmp_path: Path
) -> None:
    log = tmp_path / "killed.beatlog"
    with Recorder(tmp_path / "live.beatlog", quiet_system(), software="test"):
        log.write_bytes((tmp_path / "live.beatlog").read_bytes())  # killed before a cycle
    system = "tests.systems:quiet_system"

    refused = beatlog("replay", log, "--system", system, "--allow-truncated")
    allowed = beatlog("replay", log, "--system", system, "--allow-truncated", "--allow-empty")

    assert_error(
        refused,
        f"{log}: the replay checked nothing (0 cycles); if nothing is meant "
        "to happen in it, accept it with --allow-empty (in a spec: allow_empty = true)",
    )
    assert allowed.code == 0
    timing = r"in (under 1 ms|\d+\.\d{3} s( \([\d,.]+× real time\))?)"  # a loaded machine is slow
    assert re.fullmatch(
        rf"PASS {re.escape(str(log))}  0 cycles checked \(allowed empty\); 0\.0 s robot time "
        rf"{timing}; log truncated at cycle 0: the recording stopped before the log was closed\n",
        allowed.out,
    )


NUMPY_NEEDED = (
    "array draws (uniform_array, normal_array, integers_array) need numpy: "
    'pip install "beatlog[arrays]"'
)


def test_replaying_array_draws_without_numpy_is_one_line_naming_the_log_and_the_extra(
    beatlog: Beatlog, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_scatter(tmp_path / "arrays.beatlog")
    monkeypatch.setitem(sys.modules, "numpy", None)

    run = beatlog("replay", log, "--system", "tests.systems:scatter_system")

    assert_error(run, f"{log}: {NUMPY_NEEDED}")


def test_a_divergence_shows_recorded_array_draws_without_numpy(
    beatlog: Beatlog, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_scatter(tmp_path / "arrays.beatlog", seed=3)
    recorded = RecordingRandom(seed=3).uniform_array(0.0, 1.0, (2, 2)).tolist()  # its first draw
    monkeypatch.setitem(sys.modules, "numpy", None)

    run = beatlog("replay", log, "--system", "tests.systems:scatter_system_calm", "--json")

    assert run.code == 1
    (draw,) = json.loads(run.out)["divergence"]["random_recorded"]
    assert draw == ["scatter", "uniform_array", recorded, "uniform_array(0.0, 1.0, [2, 2])"]


def test_replay_checks_the_invariants_it_is_given_and_reproduces_with_them(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    log = record_probe(300)

    run = beatlog("replay", log, "--system", PROBE, "--invariants", "tests.systems:never_close")

    assert run.code == 1
    assert "invariant never_close does not hold: 0.3 m from the pole" in run.out
    assert whole_lines(run.out)[-1] == (
        f"reproduce: beatlog replay {log} --system {PROBE} --invariants tests.systems:never_close"
    )


def test_an_invariant_that_does_not_import_is_one_line(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    run = beatlog(
        "replay", record_probe(30), "--system", PROBE, "--invariants", "tests.systems:nothing"
    )

    assert_error(run, "'tests.systems:nothing': tests.systems has no nothing")
