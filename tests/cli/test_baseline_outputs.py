"""An approved baseline keeps every check: it pins the outputs too, ``--update`` and
``approve`` write them, ``review`` shows their changes, and a format 1 baseline (state
changes only) still judges outputs against the recording until it is re-approved."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from beatlog.cli.main import main
from beatlog.model.behavior import PriorityArbiter
from beatlog.model.context import Context, Outputs
from beatlog.suite.baseline import expected_path, pending_path, read_baseline
from tests.conftest import Dice, Near, Probe, RecordFn, distances, probe_system

HERE = "tests.cli.test_baseline_outputs"


class Geared(Dice):
    """Dice with a new motor gain near the obstacle: a change in outputs only."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        outputs = super().step(rs, ctx)
        assert outputs is not None
        return {**outputs, "speed": 0.55 if rs.distance < 0.8 else 0.5}


def earlier() -> PriorityArbiter[Probe]:
    """Near reacts at 0.6 instead of 0.5: the intended change that gets approved."""
    return probe_system(0.6)


def earlier_geared() -> PriorityArbiter[Probe]:
    """On top of the approved change, a changed motor gain."""
    return PriorityArbiter([Near(0.6), Geared()], robot_state=Probe)


GAIN_CYCLE = next(t for t, d in enumerate(distances(300)) if d < 0.8)
"""The first cycle where the changed gain changes an output."""


@pytest.fixture(autouse=True)
def not_ci_and_wide(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.setenv("COLUMNS", "200")


def beatlog(capsys: pytest.CaptureFixture[str], *argv: str | Path) -> tuple[int, str]:
    capsys.readouterr()
    code = main([str(arg) for arg in argv])
    return code, capsys.readouterr().out


def spec_file(folder: Path, log: Path, system: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    keys = {
        "name": "avoid-pole",
        "purpose": "The probe turns away from the pole.",
        "procedure": ["Drive the probe toward the pole and back, twice."],
        "log": str(log),
        "system": f"{HERE}:{system}",
    }
    path = folder / "avoid-pole.dtc.toml"
    path.write_text("".join(f"{k} = {json.dumps(v)}\n" for k, v in keys.items()), "utf-8")
    return path


@pytest.fixture
def spec(tmp_path: Path, record_probe: RecordFn, capsys: pytest.CaptureFixture[str]) -> Path:
    """A spec whose intended change (near reacts earlier) has an approved baseline."""
    spec = spec_file(tmp_path / "specs", record_probe(300), "earlier")
    assert beatlog(capsys, "test", "-j", "1", "--update", spec)[0] == 1
    assert beatlog(capsys, "approve", spec)[0] == 0
    return spec


def test_update_and_approve_pin_the_outputs(spec: Path) -> None:
    baseline = read_baseline(expected_path(spec))
    assert baseline.outputs
    assert {traced.field for traced in baseline.outputs} == {"speed", "time"}
    lines = expected_path(spec).read_text(encoding="utf-8").splitlines()
    assert lines[0] == "# beatlog expected state changes and outputs, format 2"
    assert '       0     0.030  output "speed" = 0.5' in lines


def test_a_changed_motor_gain_fails_against_the_approved_baseline(
    spec: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert beatlog(capsys, "test", "-j", "1", spec)[0] == 0
    spec_file(spec.parent, spec.parent.parent / "probe.beatlog", "earlier_geared")

    code, out = beatlog(capsys, "test", "-j", "1", spec)

    assert code == 1
    assert f"first divergence: cycle {GAIN_CYCLE}, " in out
    assert "outputs differ from the approved baseline" in out
    assert "speed = 0.5" in out
    assert "speed = 0.55" in out


def test_review_shows_the_output_changes_of_the_changed_cycles(
    spec: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec_file(spec.parent, spec.parent.parent / "probe.beatlog", "earlier_geared")
    assert beatlog(capsys, "test", "-j", "1", "--update", spec)[0] == 1

    code, out = beatlog(capsys, "review", spec)

    assert code == 0
    lines = out.splitlines()
    assert f"--- approved ({expected_path(spec).name})" in lines
    assert f'+{GAIN_CYCLE:>8}     0.360  output "speed" = 0.55' in lines
    changed = [line for line in lines if line[:1] in "+-" and line[:3] not in ("+++", "---")]
    assert all('output "speed"' in line for line in changed)  # only the gain changed
    assert len(lines) < 80  # changed cycles with a line of context, not the whole file


def test_a_format_1_baseline_judges_outputs_against_the_recording_until_re_approved(
    spec: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = expected_path(spec)
    lines = path.read_text(encoding="utf-8").splitlines()
    old = [line for line in lines[1:] if "output " not in line]
    path.write_text(
        "\n".join(["# beatlog expected state changes, format 1", *old]) + "\n", encoding="utf-8"
    )

    code, out = beatlog(capsys, "test", "-j", "1", "--update", spec)

    assert code == 1
    assert "outputs differ from the recording (the approved baseline pins no outputs" in out
    assert pending_path(spec).exists()
    assert beatlog(capsys, "approve", spec)[0] == 0
    assert read_baseline(path).outputs
    assert beatlog(capsys, "test", "-j", "1", spec)[0] == 0
