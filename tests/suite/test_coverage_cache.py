"""Coverage remembers what earlier runs saw, and reports states no DTC reaches now."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from beatlog.analysis.coverage import Seen, SuiteCoverage
from beatlog.cli.main import main
from beatlog.suite.coverage_cache import (
    CACHE_FOLDER,
    MAX_DTCS,
    MAX_STATES,
    cache_path,
    recall,
)
from tests.conftest import Probe, RecordFn
from tests.specs import PROBE, write_spec


@pytest.fixture
def specs(tmp_path: Path, record_probe: RecordFn) -> Path:
    """A suite of two DTCs: one drives the probe near the pole, one keeps it far."""
    folder = tmp_path / "specs"
    write_spec(folder, "approach", record_probe(300, name="near.beatlog"), PROBE)
    far = record_probe(40, name="far.beatlog", states=[Probe(distance=2.0)] * 40)
    write_spec(folder, "idle", far, PROBE)
    return folder


def _coverage(
    specs: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> tuple[int, str, str, dict[str, object]]:
    monkeypatch.setenv("COLUMNS", "200")
    report = specs.parent / "coverage.json"
    code = main(["test", "-j", "1", "--coverage", "--coverage-json", str(report), str(specs)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err, json.loads(report.read_text())


def test_a_state_earlier_runs_saw_that_no_dtc_reaches_now_is_reported(
    specs: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    code, out, err, document = _coverage(specs, capsys, monkeypatch)
    assert (code, err) == (0, "")
    assert "seen before" not in out
    (specs / "approach.dtc.toml").unlink()

    code, out, err, document = _coverage(specs, capsys, monkeypatch)

    assert (code, err) == (0, "")
    assert '"near" (seen before in approach)' in out
    near = document["behaviors"]["near"]  # type: ignore[index]
    assert near["no_longer_reached"] == [{"state": '"near"', "dtcs_before": ["approach"]}]
    assert {(t["before"], t["after"]) for t in near["no_longer_taken"]} == {
        ('"far"', '"near"'),
        ('"near"', '"far"'),
    }
    code, out, err, document = _coverage(specs, capsys, monkeypatch)
    assert '"near" (seen before in approach)' in out  # remembered until the cache goes


def test_a_dtc_left_out_of_a_run_did_not_lose_what_it_reached(
    specs: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    _coverage(specs, capsys, monkeypatch)
    monkeypatch.setenv("COLUMNS", "200")

    code = main(["test", "-j", "1", "--coverage", "-k", "idle", str(specs)])

    out = capsys.readouterr().out
    assert code == 0
    assert "idle" in out
    assert "seen before" not in out


def test_behaviors_this_run_does_not_have_are_remembered_not_reported(tmp_path: Path) -> None:
    path = tmp_path / CACHE_FOLDER / "coverage.json"
    earlier = SuiteCoverage(dtcs=["docking"])
    earlier.behavior("dock").states['"latched"'] = Seen({"docking"}, 5)
    recall(earlier, path, ["docking"])
    now = SuiteCoverage(dtcs=["walk"])
    now.behavior("wander").states['"roam"'] = Seen({"walk"}, 9)

    assert recall(now, path, ["walk"]).warning is None

    assert list(now.behaviors) == ["wander"]
    remembered = json.loads(path.read_text())["behaviors"]
    assert remembered == {
        "dock": {"states": {'"latched"': ["docking"]}, "transitions": []},
        "wander": {"states": {'"roam"': ["walk"]}, "transitions": []},
    }


def test_the_memory_lives_in_a_cache_folder_git_ignores(
    specs: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    _coverage(specs, capsys, monkeypatch)
    folder = specs / CACHE_FOLDER
    assert cache_path(specs) == folder / "coverage.json"
    assert (folder / ".gitignore").read_text().splitlines()[-1] == "*"
    assert (folder / "CACHEDIR.TAG").read_bytes().startswith(b"Signature: 8a477f597d28d172789f")
    remembered = json.loads((folder / "coverage.json").read_text())
    assert remembered["behaviors"]["near"]["states"]['"near"'] == ["approach"]


def test_the_memory_goes_to_the_project_root(tmp_path: Path) -> None:
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "robot"\n')
    suite = tmp_path / "tests" / "dtc"
    suite.mkdir(parents=True)
    assert cache_path(suite) == tmp_path.resolve() / CACHE_FOLDER / "coverage.json"


@pytest.mark.parametrize(
    "content",
    [
        b"not json",
        b'{"version": 2, "behaviors": {}}',
        b'{"version": 1, "behaviors": {"near": {"states": {"\\"far\\"": 3}, "transitions": []}}}',
        json.dumps(
            {"version": 1, "behaviors": {"near": {"states": {"x": ["d"] * 9}, "transitions": []}}}
        ).encode(),
        b"[" * 100_000,
    ],
    ids=["garbage", "other-version", "wrong-type", "too-many-dtcs", "nested-deep"],
)
def test_a_damaged_memory_is_a_warning_and_is_replaced(
    specs: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    content: bytes,
) -> None:
    path = cache_path(specs)
    path.parent.mkdir()
    path.write_bytes(content)

    code, out, err, _ = _coverage(specs, capsys, monkeypatch)

    assert code == 0
    assert err.startswith(f"beatlog: warning: {path}: not a beatlog coverage memory")
    assert err.count("\n") == 1
    assert "transition coverage" in out
    assert json.loads(path.read_text())["version"] == 1


def test_an_unwritable_memory_is_a_warning(
    specs: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    (specs / CACHE_FOLDER).write_text("a file where the folder goes")
    code, _, err, _ = _coverage(specs, capsys, monkeypatch)
    assert code == 0
    assert err.startswith("beatlog: warning: ")
    assert "cannot write" in err


def test_the_memory_is_bounded(tmp_path: Path) -> None:
    coverage = SuiteCoverage()
    busy = coverage.behavior("busy")
    for state in range(MAX_STATES + 10):
        busy.states[json.dumps(state)] = Seen({f"dtc{n}" for n in range(MAX_DTCS + 3)}, 1)
    path = tmp_path / CACHE_FOLDER / "coverage.json"
    assert recall(coverage, path, []).warning is None

    remembered = json.loads(path.read_text())["behaviors"]["busy"]["states"]
    assert len(remembered) == MAX_STATES
    assert all(len(dtcs) == MAX_DTCS for dtcs in remembered.values())
    again = SuiteCoverage()
    again.behavior("busy")
    assert recall(again, path, []).warning is None
    assert len(again.behaviors["busy"].no_longer_reached) == MAX_STATES
