"""The re-baselining workflow as a library: an intended change goes to a pending file,
is reviewed as a diff, accepted or rejected; accepted baselines are never overwritten by
a failure, and nothing is written when ``CI`` is set."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from beatlog.baseline.file import expected_path, pending_path, read_baseline
from beatlog.baseline.policy import UpdateMode
from beatlog.errors import BaselineError, CiWriteError, OptionError
from beatlog.replay.verdict import DivergenceKind
from beatlog.suite.maintenance import (
    Decision,
    UpdateAction,
    approve,
    decide,
    find_orphans,
    pending_diff,
    pending_specs,
    update_baselines,
)
from beatlog.suite.parallel import run_suite
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.spec import DtcSpec, load_spec
from tests.conftest import RecordFn
from tests.specs import write_spec

AS_RECORDED = "tests.conftest:probe_system"
CHANGED = "tests.conftest:probe_system_changed"
FRAGILE = "tests.systems:fragile_system"


def write_dtc(folder: Path, log: Path, system: str, name: str = "avoid-pole") -> DtcSpec:
    """The spec ``<folder>/<name>.dtc.toml`` replaying ``log`` against ``system``."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.dtc.toml"
    keys = {
        "name": name,
        "purpose": "The probe stops near the pole.",
        "procedure": ["Drive the probe toward the pole and back, twice."],
        "log": str(log),
        "system": system,
    }
    path.write_text("".join(f"{k} = {json.dumps(v)}\n" for k, v in keys.items()), "utf-8")
    return load_spec(path)


def run(spec: DtcSpec, mode: UpdateMode | str = UpdateMode.NEW) -> list[SpecOutcome]:
    return run_suite([spec], update=mode)


@pytest.fixture
def log(record_probe: RecordFn) -> Path:
    return record_probe(300)


@pytest.fixture
def changed(tmp_path: Path, log: Path) -> DtcSpec:
    """A spec whose behaviors changed on purpose since the recording."""
    return write_dtc(tmp_path / "specs", log, CHANGED)


@pytest.fixture
def pending(changed: DtcSpec) -> DtcSpec:
    """The changed spec with its new baseline pending."""
    update_baselines(run(changed), UpdateMode.NEW)
    return changed


def test_a_failure_writes_its_new_expectation_to_the_pending_file_only(
    changed: DtcSpec,
) -> None:
    outcomes = run(changed)

    (update,) = update_baselines(outcomes, UpdateMode.NEW)

    assert update.action is UpdateAction.WRITTEN
    assert update.path == pending_path(changed.path)
    written = read_baseline(update.path)
    assert update.shift is not None
    assert (update.shift.lost, update.shift.gained, update.shift.moved) == (0, 0, 12)
    assert update.shift.open_loop == written.whole.open_loop[0]  # type: ignore[index]
    assert update.baseline is not None
    assert len(update.baseline.outputs) == len(written.whole.outputs)
    assert not expected_path(changed.path).exists()


def test_the_none_mode_writes_nothing(changed: DtcSpec) -> None:
    assert update_baselines(run(changed), UpdateMode.NONE) == []
    assert update_baselines(run(changed, "none"), "new") == []  # no expectation was traced
    assert not pending_path(changed.path).exists()


def test_an_unknown_update_mode_is_an_option_error(changed: DtcSpec) -> None:
    with pytest.raises(OptionError, match="choose one of 'none', 'new'"):
        run(changed, "sometimes")
    with pytest.raises(OptionError, match="unknown update mode 'all'"):
        update_baselines([], "all")


def test_in_ci_the_new_expectation_is_withheld(
    changed: DtcSpec, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("CI", "true")

    (update,) = update_baselines(run(changed), UpdateMode.NEW)

    assert update.action is UpdateAction.WITHHELD
    assert update.shift is not None
    assert update.shift.moved > 0
    assert not pending_path(changed.path).exists()


def test_a_behavior_that_raises_is_refused_with_the_reason(tmp_path: Path, log: Path) -> None:
    fragile = write_dtc(tmp_path / "specs", log, FRAGILE)

    (update,) = update_baselines(run(fragile), UpdateMode.NEW)

    assert update.action is UpdateAction.REFUSED
    assert update.reason == (
        "a behavior raised: an exception is a bug, never a baseline; fix it first"
    )
    assert not pending_path(fragile.path).exists()


def test_a_passing_dtc_loses_its_stale_pending_file(pending: DtcSpec, log: Path) -> None:
    undone = write_dtc(pending.path.parent, log, AS_RECORDED)  # the change was undone

    (update,) = update_baselines(run(undone), UpdateMode.NEW)

    assert update.action is UpdateAction.REMOVED
    assert not pending_path(undone.path).exists()


def test_a_failure_never_overwrites_the_approved_baseline(pending: DtcSpec, log: Path) -> None:
    decide(pending, Decision.ACCEPT)
    approved = expected_path(pending.path).read_bytes()
    undone = write_dtc(pending.path.parent, log, AS_RECORDED)  # now differs from the approved

    (update,) = update_baselines(run(undone), UpdateMode.NEW)

    assert update.action is UpdateAction.WRITTEN
    assert expected_path(undone.path).read_bytes() == approved


@pytest.mark.parametrize("decision", list(Decision))
def test_each_decision_does_what_it_says(pending: DtcSpec, decision: Decision) -> None:
    waiting = read_baseline(pending_path(pending.path)).whole  # read before it moves

    decide(pending, decision.value)

    assert pending_path(pending.path).exists() is (decision is Decision.SKIP)
    assert expected_path(pending.path).exists() is (decision is Decision.ACCEPT)
    if decision is Decision.ACCEPT:
        assert read_baseline(expected_path(pending.path)).whole.changes == waiting.changes


def test_an_unknown_decision_names_the_decisions_there_are(pending: DtcSpec) -> None:
    waiting = pending_path(pending.path).read_bytes()
    with pytest.raises(OptionError) as raised:
        decide(pending, "maybe")
    assert str(raised.value) == "unknown decision 'maybe': choose one of 'accept', 'reject', 'skip'"
    assert pending_path(pending.path).read_bytes() == waiting


@pytest.mark.parametrize("decision", [Decision.ACCEPT, Decision.REJECT])
def test_no_decision_is_written_in_ci(
    pending: DtcSpec, decision: Decision, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("CI", "1")
    waiting = pending_path(pending.path).read_bytes()

    with pytest.raises(CiWriteError):
        decide(pending, decision)
    decide(pending, Decision.SKIP)

    assert pending_path(pending.path).read_bytes() == waiting
    assert not expected_path(pending.path).exists()


def test_a_pending_file_from_another_recording_is_never_accepted(
    pending: DtcSpec, log: Path, record_probe: RecordFn
) -> None:
    record_probe(200, name="rerecorded.beatlog").replace(log)
    waiting = pending_path(pending.path).read_bytes()

    with pytest.raises(BaselineError, match=r"made from another recording than probe\.beatlog"):
        decide(pending, Decision.ACCEPT)

    assert pending_path(pending.path).read_bytes() == waiting
    assert not expected_path(pending.path).exists()


def test_approve_accepts_everything_pending_in_a_folder(pending: DtcSpec, log: Path) -> None:
    write_dtc(pending.path.parent, log, AS_RECORDED, name="untouched")
    folder = pending.path.parent
    waiting = pending_path(pending.path).read_bytes()

    assert pending_specs([folder]) == [pending]
    assert [spec for spec, _ in approve([folder])] == [pending]
    assert pending_specs([folder]) == []
    assert expected_path(pending.path).read_bytes() == waiting


def test_approve_with_nothing_pending_or_in_ci_writes_nothing(
    pending: DtcSpec, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    (tmp_path / "elsewhere").mkdir()
    assert approve([tmp_path / "elsewhere"]) == []
    monkeypatch.setenv("CI", "true")
    with pytest.raises(CiWriteError):
        approve([pending.path])
    assert not expected_path(pending.path).exists()


def test_the_pending_diff_compares_with_the_recording_then_the_approved_baseline(
    pending: DtcSpec, log: Path
) -> None:
    first = pending_diff(pending)
    assert first.source == "recorded (probe.beatlog)"
    assert first.lines[:2] == ("--- recorded (probe.beatlog)", "+++ pending")
    assert any(line.startswith("+") and '"near"' in line for line in first.lines[2:])

    decide(pending, Decision.ACCEPT)
    undone = write_dtc(pending.path.parent, log, AS_RECORDED)
    update_baselines(run(undone), UpdateMode.NEW)

    again = pending_diff(undone)
    assert again.source == "approved (avoid-pole.dtc.expected)"
    assert again.lines[:2] == ("--- approved (avoid-pole.dtc.expected)", "+++ pending")
    assert any(line.startswith("-") and '"near"' in line for line in again.lines[2:])


def test_a_dtc_whose_robot_state_field_was_renamed_re_baselines_as_any_other(
    tmp_path: Path, log: Path
) -> None:
    """``distance`` became ``range`` and near reacts earlier: with the rename in the
    spec, the change is a divergence like any other, approved, then guarded."""

    def dtc(system: str) -> DtcSpec:
        renamed = {"distance": "range"}
        return load_spec(write_spec(tmp_path, "ranged", log, system, field_renames=renamed))

    changed = dtc("tests.systems:probe_system_ranged_changed")
    (diverged,) = run(changed)
    assert diverged.verdict is Verdict.FAILED
    (update,) = update_baselines([diverged], UpdateMode.NEW)
    assert update.action is UpdateAction.WRITTEN

    assert [spec for spec, _ in approve([changed.path])] == [changed]
    (approved,) = run(changed, UpdateMode.NONE)
    assert approved.verdict is Verdict.PASSED

    (broken,) = run(dtc("tests.systems:probe_system_ranged_broken"), UpdateMode.NONE)
    assert broken.verdict is Verdict.FAILED
    assert broken.result is not None
    assert broken.result.divergence is not None
    assert broken.result.divergence.kind is DivergenceKind.STATE_CHANGES


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
