"""The dog's own history: every intended change kept by re-baselining, never by a new
recording, and a bug planted afterwards caught (the promise of a suite that lives)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from beatlog.baseline.policy import UpdateMode
from beatlog.suite.discovery import discover_specs
from beatlog.suite.maintenance import UpdateAction, approve, update_baselines
from beatlog.suite.parallel import run_suite
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.spec import DtcSpec
from beatlog_examples.dog import SUITE_DIR
from beatlog_examples.dog.history import CHANGES, PLANTED_BUG, Change, changed_dog

DTCS = ("chin-touch", "escape-bump", "avoid-box", "head-pat")
"""Short DTCs that between them notice every change of the history."""


def step(folder: Path, suite: Path, number: int, changes: list[Change]) -> list[DtcSpec]:
    """The suite's specs, pointed at the dog with ``changes`` applied."""
    system = changed_dog(folder, f"dog_history_{number}", changes)
    package = system.partition(":")[0]
    for name in DTCS:
        spec = suite / f"{name}.dtc.toml"
        text = (SUITE_DIR / f"{name}.dtc.toml").read_text(encoding="utf-8")
        text = text.replace("beatlog_examples.dog:system", system)
        text = text.replace("beatlog_examples.dog.perception", f"{package}.perception")
        spec.write_text(text, encoding="utf-8")
    return discover_specs([suite])


def failed(outcomes: list[SpecOutcome]) -> list[str]:
    return [o.spec.name for o in outcomes if o.verdict is not Verdict.PASSED]


@pytest.fixture
def suite(tmp_path: Path) -> Path:
    folder = tmp_path / "dtc"
    folder.mkdir()
    for name in DTCS:
        shutil.copy(SUITE_DIR / f"{name}.beatlog", folder)
    return folder


@pytest.mark.slow
def test_every_intended_change_is_kept_and_a_planted_bug_is_caught_after(
    tmp_path: Path, suite: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.syspath_prepend(str(tmp_path))
    logs = {path: path.read_bytes() for path in suite.glob("*.beatlog")}
    noticed: dict[str, list[str]] = {}
    for number, change in enumerate(CHANGES, 1):
        specs = step(tmp_path, suite, number, list(CHANGES[:number]))
        before = run_suite(specs, update=UpdateMode.NEW)
        noticed[change.title] = failed(before)
        updates = update_baselines(before, UpdateMode.NEW)
        assert [u.action for u in updates] == [UpdateAction.WRITTEN] * len(failed(before))
        if updates:
            approve([suite])
        assert failed(run_suite(specs)) == [], change.title

    planted = step(tmp_path, suite, len(CHANGES) + 1, [*CHANGES, PLANTED_BUG])

    assert failed(run_suite(planted)) != []
    assert {path: path.read_bytes() for path in suite.glob("*.beatlog")} == logs
    baselines = sum(path.stat().st_size for path in suite.glob("*.dtc.expected"))
    assert baselines <= 0.05 * sum(map(len, logs.values()))  # where it departs, no copy
    unnoticed = [title for title, names in noticed.items() if not names]
    assert set(unnoticed) <= {"two behaviors swapped in priority"}  # the rest is kept above
