"""One rule for approved baselines: ``beatlog.replay`` and ``beatlog replay`` judge a log
as ``beatlog test`` judges the spec beside it."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import beatlog
from beatlog.baseline.policy import UpdateMode
from beatlog.cli.main import main
from beatlog.errors import BaselineError
from beatlog.suite.approved import approved_baseline, approved_baselines
from beatlog.suite.discovery import discover_specs
from beatlog.suite.maintenance import approve, update_baselines
from beatlog.suite.parallel import run_suite
from tests.commands import closing_counts
from tests.conftest import RecordFn
from tests.specs import write_spec
from tests.text import table_row, whole_lines

GREEDY = "tests.systems:probe_system_greedy"


@pytest.fixture
def log(record_probe: RecordFn) -> Path:
    """A probe log with a spec beside it whose greedy change is approved."""
    path = record_probe(300)
    write_spec(path.parent, "avoid-pole", path, GREEDY)
    specs = discover_specs([path.parent])
    update_baselines(run_suite(specs, update=UpdateMode.NEW), UpdateMode.NEW)
    approve([path.parent])
    return path


def test_the_python_api_judges_against_the_approved_baseline_of_the_spec_beside(
    log: Path,
) -> None:
    result = beatlog.replay(log, GREEDY)

    assert (result.ok, result.divergence, result.cycles) == (True, None, 300)
    assert result.notes[0] == (
        "judged against the approved baseline avoid-pole.dtc.expected, "
        f"as beatlog test {log.parent / 'avoid-pole.dtc.toml'} judges it"
    )
    assert not beatlog.replay(log, GREEDY, approved=False).ok


def test_the_replay_command_passes_what_test_passes_and_says_why(
    log: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["replay", str(log), "--system", GREEDY])
    passed = capsys.readouterr().out
    recording = main(["replay", str(log), "--system", GREEDY, "--recording"])
    failed = capsys.readouterr().out

    assert code == 0
    assert (
        "note: judged against the approved baseline avoid-pole.dtc.expected, as beatlog test "
        f"{log.parent / 'avoid-pole.dtc.toml'} judges it"
    ) in whole_lines(passed)
    assert recording == 1
    assert f"reproduce: beatlog replay {log} --system {GREEDY} --recording" in whole_lines(failed)


def test_a_log_no_spec_names_is_judged_against_its_recording(
    record_probe: RecordFn, tmp_path: Path
) -> None:
    other = record_probe(300, name="other.beatlog")
    write_spec(tmp_path, "elsewhere", record_probe(300, name="named.beatlog"))

    assert approved_baseline(other) is None


def test_a_spec_beside_the_log_that_cannot_be_read_names_nothing(log: Path) -> None:
    (log.parent / "broken.dtc.toml").write_text('log = "probe.beatlog"\n[[', encoding="utf-8")
    (log.parent / "huge.dtc.toml").write_bytes(b"#" * (1 << 21))

    assert [found.spec.name for found in approved_baselines(log)] == ["avoid-pole"]


def test_a_baseline_approved_for_another_recording_is_an_error(
    log: Path, record_probe: RecordFn
) -> None:
    record_probe(300, name="again.beatlog", seed=8).replace(log)

    with pytest.raises(BaselineError, match=r"approved for another recording than probe\.beatlog"):
        beatlog.replay(log, GREEDY)


def test_two_specs_with_approved_baselines_for_one_log_are_an_error(log: Path) -> None:
    twin = log.parent / "twin.dtc.toml"
    shutil.copy(log.parent / "avoid-pole.dtc.toml", twin)
    twin.write_text(twin.read_text().replace('"avoid-pole"', '"twin"'))
    shutil.copy(log.parent / "avoid-pole.dtc.expected", log.parent / "twin.dtc.expected")

    with pytest.raises(BaselineError, match=r"avoid-pole\.dtc\.toml, twin\.dtc\.toml name it"):
        beatlog.replay(log, GREEDY)


def test_of_several_specs_naming_a_log_the_one_of_the_system_replayed_is_its_spec(
    log: Path,
) -> None:
    write_spec(log.parent, "as-recorded", log)

    assert beatlog.replay(log, GREEDY).ok
    as_recorded = beatlog.replay(log, "tests.conftest:probe_system")
    assert (as_recorded.ok, as_recorded.divergence, as_recorded.counts) == (
        True,
        None,
        {"cycles": 300, "state_changes": 45, "outputs": 453, "draws": 60, "samples": 0},
    )
    assert as_recorded.notes == ()


def test_show_and_test_name_the_approved_baseline_and_where_it_goes_open_loop(
    log: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "200")
    approved = approved_baseline(log)
    assert approved is not None
    assert approved.baseline.whole.open_loop is not None
    cycle, time_ns = approved.baseline.whole.open_loop

    main(["show", str(log)])
    shown = capsys.readouterr().out
    main(["test", "-v", "-j", "1", str(log.parent)])
    tested = capsys.readouterr().out

    assert shown.splitlines()[-1] == (
        "approved baseline avoid-pole.dtc.expected (spec avoid-pole.dtc.toml): "
        f"open loop since cycle {cycle} ({time_ns / 1e9:.3f} s)"
    )
    assert table_row(tested, "avoid-pole")[:4] == [
        "avoid-pole",
        f"passed (approved baseline, open loop since cycle {cycle})",
        "300",
        "9.0 s",
    ]
    assert closing_counts(tested) == (
        "1 passed, 0 failed, 1 open loop (worth re-recording when convenient)"
    )
