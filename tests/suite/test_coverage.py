"""Coverage remembers what earlier runs saw, and reports states no DTC reaches now."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from beatlog.analysis.coverage import Seen, SuiteCoverage
from beatlog.cli.main import main
from beatlog.suite.coverage import (
    CACHE_FOLDER,
    MAX_DTCS,
    MAX_STATES,
    cache_path,
    recall,
)
from tests.conftest import Probe, RecordFn
from tests.specs import PROBE, write_spec
from tests.text import table_row, whole_lines


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
    assert table_row(out, "near") == [
        "near",
        '"far" (1 DTC, 40 cycles)',
        "none",
        '"near" (seen before in approach)',
    ]
    near = document["systems"][PROBE]["near"]  # type: ignore[index]
    assert near["no_longer_reached"] == [
        {"state": '"near"', "dtcs_before": ["approach.dtc.toml::approach"]}
    ]
    assert {(t["before"], t["after"]) for t in near["no_longer_taken"]} == {
        ('"far"', '"near"'),
        ('"near"', '"far"'),
    }
    code, out, err, document = _coverage(specs, capsys, monkeypatch)
    # remembered until the cache goes
    assert table_row(out, "near")[-1] == '"near" (seen before in approach)'


def test_a_dtc_left_out_of_a_run_did_not_lose_what_it_reached(
    specs: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    _coverage(specs, capsys, monkeypatch)
    monkeypatch.setenv("COLUMNS", "200")

    code = main(["test", "-j", "1", "--coverage", "-k", "idle", str(specs)])

    out = capsys.readouterr().out
    assert code == 0
    assert table_row(out, "idle")[:4] == ["idle", "passed", "40", "1.2 s"]
    assert "seen before" not in out


def test_behaviors_this_run_does_not_have_are_remembered_not_reported(tmp_path: Path) -> None:
    path = tmp_path / CACHE_FOLDER / "coverage.json"
    earlier = SuiteCoverage(dtcs=["docking"])
    earlier.behavior("rover", "dock").states['"latched"'] = Seen({"docking"}, 5)
    recall(earlier, path, {"docking": "docking"})
    now = SuiteCoverage(dtcs=["walk"])
    now.behavior("rover", "wander").states['"roam"'] = Seen({"walk"}, 9)

    assert recall(now, path, {"walk": "walk"}) is None

    assert [cover.behavior for cover in now.behaviors] == ["wander"]
    remembered = json.loads(path.read_text())["systems"]
    assert remembered == {
        "rover": {
            "dock": {"states": {'"latched"': ["docking"]}, "transitions": []},
            "wander": {"states": {'"roam"': ["walk"]}, "transitions": []},
        }
    }


def test_a_version_1_memory_is_read_by_ids_and_its_behaviors_go_to_their_system(
    specs: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    path = cache_path(specs)
    path.parent.mkdir()
    near = {
        "states": {'"near"': ["approach"], '"asleep"': ["dozing"]},
        "transitions": [['"far"', '"asleep"', ["dozing"]]],
    }
    gone = {"states": {'"docked"': ["docking"]}, "transitions": []}
    path.write_text(json.dumps({"version": 1, "behaviors": {"near": near, "gone": gone}}))
    monkeypatch.setenv("COLUMNS", "200")

    code = main(["test", "-j", "1", "--coverage", "-k", "idle", str(specs)])

    out, err = capsys.readouterr()
    assert (code, err) == (0, "")
    [row] = [line.strip("│").split("│") for line in out.splitlines() if line.startswith("│ near ")]
    assert [cell.strip() for cell in row] == [
        "near",
        '"far" (1 DTC, 40 cycles)',
        "none",
        '"asleep" (seen before in dozing)',  # approach, left out by -k, lost nothing
    ]
    remembered = json.loads(path.read_text())
    assert remembered["version"] == 2
    assert remembered["systems"][PROBE]["near"] == {
        "states": {
            '"near"': ["approach.dtc.toml::approach"],
            '"asleep"': ["dozing"],
            '"far"': ["idle.dtc.toml::idle"],
        },
        "transitions": [['"far"', '"asleep"', ["dozing"]]],
    }
    assert remembered["systems"][""] == {"gone": gone}  # no system of this run has it


def test_a_dtc_only_earlier_runs_saw_is_named_by_its_id_where_another_has_its_name(
    tmp_path: Path,
) -> None:
    path = tmp_path / CACHE_FOLDER / "coverage.json"
    x, y, other_x = "dog/x.dtc.toml::x", "dog/y.dtc.toml::y", "rover/x.dtc.toml::x"
    earlier = SuiteCoverage(dtcs=[x, y])
    dock = earlier.behavior("robot", "dock")
    dock.states = {'"latched"': Seen({x}, 5), '"waiting"': Seen({y}, 5)}
    recall(earlier, path, {x: "x", y: "y"})
    now = SuiteCoverage(dtcs=[other_x])
    now.behavior("robot", "dock").states['"idle"'] = Seen({other_x}, 9)

    assert recall(now, path, {other_x: "x"}) is None

    assert now.labels == {x: x, y: "y"}


def test_the_memory_lives_in_a_cache_folder_git_ignores(
    specs: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    _coverage(specs, capsys, monkeypatch)
    folder = specs / CACHE_FOLDER
    assert cache_path(specs) == folder / "coverage.json"
    assert (folder / ".gitignore").read_text().splitlines()[-1] == "*"
    assert (folder / "CACHEDIR.TAG").read_bytes().startswith(b"Signature: 8a477f597d28d172789f")
    remembered = json.loads((folder / "coverage.json").read_text())
    assert remembered["version"] == 2
    assert remembered["systems"][PROBE]["near"]["states"]['"near"'] == [
        "approach.dtc.toml::approach"
    ]


def test_the_memory_goes_to_the_project_root(tmp_path: Path) -> None:
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "robot"\n')
    suite = tmp_path / "tests" / "dtc"
    suite.mkdir(parents=True)
    assert cache_path(suite) == tmp_path.resolve() / CACHE_FOLDER / "coverage.json"


@pytest.mark.parametrize(
    "content",
    [
        b"not json",
        b'{"version": 3, "systems": {}}',
        b'{"version": 2, "behaviors": {}}',
        b'{"version": 1, "behaviors": {"near": {"states": {"\\"far\\"": 3}, "transitions": []}}}',
        json.dumps(
            {"version": 1, "behaviors": {"near": {"states": {"x": ["d"] * 9}, "transitions": []}}}
        ).encode(),
        b"[" * 100_000,
    ],
    ids=[
        "garbage",
        "other-version",
        "version-1-in-2",
        "wrong-type",
        "too-many-dtcs",
        "nested-deep",
    ],
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
    assert re.fullmatch(  # msgspec's words for what it could not decode, in parentheses
        re.escape(f"beatlog: warning: {path}: not a beatlog coverage memory (")
        + ".+"
        + re.escape("); ignored, and replaced by what this run saw\n"),
        err,
    ), err
    assert "transition coverage" in whole_lines(out)
    assert json.loads(path.read_text())["version"] == 2


def test_an_unwritable_memory_is_a_warning(
    specs: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    (specs / CACHE_FOLDER).write_text("a file where the folder goes")
    code, _, err, _ = _coverage(specs, capsys, monkeypatch)
    assert code == 0
    assert err == (
        f"beatlog: warning: {specs / CACHE_FOLDER / 'coverage.json'}: cannot write: File exists; "
        "nothing remembered\n"
    )


def test_the_memory_is_bounded(tmp_path: Path) -> None:
    coverage = SuiteCoverage()
    busy = coverage.behavior("robot", "busy")
    for state in range(MAX_STATES + 10):
        busy.states[json.dumps(state)] = Seen({f"dtc{n}" for n in range(MAX_DTCS + 3)}, 1)
    path = tmp_path / CACHE_FOLDER / "coverage.json"
    assert recall(coverage, path, {}) is None

    remembered = json.loads(path.read_text())["systems"]["robot"]["busy"]["states"]
    assert len(remembered) == MAX_STATES
    assert all(len(dtcs) == MAX_DTCS for dtcs in remembered.values())
    again = SuiteCoverage()
    busy = again.behavior("robot", "busy")
    assert recall(again, path, {}) is None
    assert len(busy.no_longer_reached) == MAX_STATES
