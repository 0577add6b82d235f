"""The patrol tree's committed DTCs: they pass, the script re-records them byte for byte,
and their replay reads no wall clock and no global random generator."""

from __future__ import annotations

import platform
from pathlib import Path

import pytest

from beatlog.audit.replays import AuditReport, audit
from beatlog.log.reader import SessionLogReader
from beatlog.suite.discovery import discover_specs
from beatlog.suite.parallel import run_suite
from beatlog.suite.runner import Verdict
from beatlog.suite.spec import DtcSpec
from beatlog_examples.trees import SUITE_DIR
from beatlog_examples.trees.record import SCENARIOS, main

SPECS = discover_specs([SUITE_DIR])


def test_both_dtcs_pass_against_the_current_tree() -> None:
    assert sorted(spec.name for spec in SPECS) == sorted(s.name for s in SCENARIOS)
    outcomes = run_suite(SPECS)
    assert [o.spec.name for o in outcomes if o.verdict is not Verdict.PASSED] == []


def test_recording_again_gives_the_committed_files(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    recorded_under = set()
    for spec in SPECS:
        with SessionLogReader(spec.log) as reader:
            recorded_under.add(reader.header.recorded_python())
    (python,) = recorded_under  # the header names it: any Python records the same bytes
    monkeypatch.setattr(platform, "python_version", lambda: python)

    assert main([str(tmp_path)]) == 0
    for spec in SPECS:
        assert (tmp_path / spec.log.name).read_bytes() == spec.log.read_bytes()
        assert (tmp_path / spec.path.name).read_text() == spec.path.read_text()


def test_a_log_already_recorded_is_kept_and_named_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([str(tmp_path), "--only", "patrol"]) == 0
    recorded = (tmp_path / "patrol.beatlog").read_bytes()
    capsys.readouterr()

    with pytest.raises(SystemExit) as exit_:
        main([str(tmp_path), "--only", "patrol"])

    assert exit_.value.code == 2
    assert capsys.readouterr().err == (
        f"error: {tmp_path / 'patrol.beatlog'}: already recorded; --overwrite records it again\n"
    )
    assert (tmp_path / "patrol.beatlog").read_bytes() == recorded
    assert main([str(tmp_path), "--only", "patrol", "--overwrite"]) == 0


def test_one_case_is_recorded_alone(tmp_path: Path) -> None:
    assert main([str(tmp_path), "--only", "patrol"]) == 0
    assert sorted(path.name for path in tmp_path.iterdir()) == [
        "patrol.beatlog",
        "patrol.dtc.toml",
    ]


@pytest.mark.parametrize(
    "spec",
    [  # each audit starts fresh interpreters: one DTC by default, the other under -m slow
        pytest.param(
            spec, id=spec.name, marks=() if spec.name == "low-battery" else pytest.mark.slow
        )
        for spec in SPECS
    ],
)
def test_replay_reads_no_wall_clock_and_no_global_random(spec: DtcSpec) -> None:
    report = audit(spec.log, "beatlog_examples.trees:system")
    assert report == AuditReport(findings=(), runs=report.runs, hash_seed_dependence=None)
    assert report.lines() == []
