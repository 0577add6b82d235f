"""Baseline files: a text format that diffs cleanly, reads back exactly, and never runs code."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.engine.trace import Expectation, TracedChange
from beatlog.engine.verdict import StateChange
from beatlog.errors import BaselineError
from beatlog.suite.baseline import (
    expected_path,
    find_orphans,
    in_ci,
    log_digest,
    pending_path,
    read_baseline,
    write_baseline,
)

CHANGES = (
    TracedChange(0, 30_000_000, StateChange("arbiter", "idle", "wander")),
    TracedChange(12, 360_012_000, StateChange("avoid", "off", "turning")),
    TracedChange(12, 360_012_000, StateChange('odd "name": ->', 3, None)),
    TracedChange(4001, 120_030_000_000, StateChange("dock ü", True, False)),
)


@pytest.fixture
def log(tmp_path: Path) -> Path:
    path = tmp_path / "session.beatlog"
    path.write_bytes(b"a recording")
    return path


def test_a_baseline_reads_back_what_was_written(tmp_path: Path, log: Path) -> None:
    path = tmp_path / "a.dtc.expected"
    write_baseline(path, spec_name="a", log=log, expectation=Expectation(CHANGES, ()))

    baseline = read_baseline(path)

    assert baseline.log_digest == log_digest(log)
    assert [(c.cycle, c.change) for c in baseline.changes] == [(c.cycle, c.change) for c in CHANGES]
    assert [c.time_ns for c in baseline.changes] == [
        30_000_000,
        360_000_000,
        360_000_000,
        120_030_000_000,
    ]
    assert baseline.expectation.changes_by_cycle()[12] == [CHANGES[1].change, CHANGES[2].change]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.dtc.expected", "session.beatlog"]


def test_a_baseline_is_one_readable_line_per_state_change(tmp_path: Path, log: Path) -> None:
    path = tmp_path / "a.dtc.pending"
    write_baseline(path, spec_name="a", log=log, expectation=Expectation(CHANGES[:2], ()))

    lines = path.read_text(encoding="utf-8").splitlines()

    assert lines[0] == "# beatlog expected state changes and outputs, format 2"
    assert lines[2] == f"# log session.beatlog sha256 {log_digest(log)}"
    assert lines[-2:] == [
        '       0     0.030  "arbiter": "idle" -> "wander"',
        '      12     0.360  "avoid": "off" -> "turning"',
    ]


def test_an_empty_baseline_is_valid(tmp_path: Path, log: Path) -> None:
    path = tmp_path / "a.dtc.expected"
    write_baseline(path, spec_name="a", log=log, expectation=Expectation((), ()))
    assert read_baseline(path).changes == ()


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("", "not a beatlog baseline"),
        ("cycle,behavior\n1,a\n", "not a beatlog baseline"),
        ("# beatlog expected state changes, format 1\n", "no '# log NAME sha256 DIGEST' line"),
        ("HEADER\n  7  0.210  avoid: 1 -> 2\n", "line 5"),
        ('HEADER\n  7  0.210  "avoid" 1 -> 2\n', "expected ':' at column 8"),
        ('HEADER\n  7  0.210  "avoid": 1 => 2\n', "line 5: expected '->'"),
        ('HEADER\n  7  0.210  "avoid": 1 -> 2 -> 3\n', "unexpected ' -> 3'"),
        ('HEADER\n  7  0.210  "a": {"__class__": "os.system"} -> 2\n', "a state must be"),
        ('HEADER\n  7  0.210  "a": [1] -> 2\n', "a state must be"),
        ("HEADER\n  7  0.210  3: 1 -> 2\n", "the behavior must be a JSON string"),
        ('HEADER\n  x  0.210  "a": 1 -> 2\n', "line 5: expected 'CYCLE TIME"),
    ],
)
def test_a_damaged_or_foreign_baseline_is_an_error_naming_file_and_line(
    tmp_path: Path, text: str, problem: str
) -> None:
    header = (
        "# beatlog expected state changes, format 1\n# spec a\n"
        f"# log a.beatlog sha256 {'0' * 64}\n# comment"
    )
    path = tmp_path / "a.dtc.expected"
    path.write_text(text.replace("HEADER", header), encoding="utf-8")

    with pytest.raises(BaselineError) as raised:
        read_baseline(path)

    assert str(raised.value).startswith(f"{path}: ")
    assert problem in str(raised.value)


def test_a_missing_baseline_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(BaselineError, match="no such file"):
        read_baseline(tmp_path / "gone.dtc.expected")


def test_baseline_files_sit_beside_their_spec() -> None:
    spec = Path("specs/avoid-pole.dtc.toml")
    assert expected_path(spec) == Path("specs/avoid-pole.dtc.expected")
    assert pending_path(spec) == Path("specs/avoid-pole.dtc.pending")


def test_orphans_are_baselines_without_a_spec(tmp_path: Path) -> None:
    for name in ("kept.dtc.toml", "kept.dtc.expected", "gone.dtc.expected", "gone.dtc.pending"):
        (tmp_path / "specs" / name).parent.mkdir(exist_ok=True)
        (tmp_path / "specs" / name).write_text("", encoding="utf-8")
    (tmp_path / "specs" / ".cache").mkdir()
    (tmp_path / "specs" / ".cache" / "old.dtc.expected").write_text("", encoding="utf-8")

    assert find_orphans([tmp_path]) == [
        tmp_path / "specs" / "gone.dtc.expected",
        tmp_path / "specs" / "gone.dtc.pending",
    ]


@pytest.mark.parametrize(
    ("value", "ci"),
    [(None, False), ("", False), ("0", False), ("false", False), ("true", True), ("1", True)],
)
def test_ci_is_recognised_from_the_environment(
    monkeypatch: pytest.MonkeyPatch, value: str | None, *, ci: bool
) -> None:
    if value is None:
        monkeypatch.delenv("CI", raising=False)
    else:
        monkeypatch.setenv("CI", value)
    assert in_ci() is ci
