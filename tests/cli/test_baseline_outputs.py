"""An approved baseline keeps every check: it pins the outputs too, ``--update`` and
``approve`` write them, ``review`` shows their changes, and a baseline of an older
format, refused until upgraded, upgrades to the departures it stood for (a format 1
one, state changes only, to outputs as recorded)."""

from __future__ import annotations

import io
from pathlib import Path

import pytest

from beatlog.analysis.trace import whole_trace
from beatlog.baseline.file import expected_path, read_baseline
from beatlog.baseline.write import format_lines
from tests.commands import Beatlog
from tests.conftest import RecordFn, first_cycle_below
from tests.specs import CHANGED, write_spec
from tests.text import table_row, whole_lines

GEARED = "tests.systems:probe_system_changed_geared"

GAIN_CYCLE = first_cycle_below(0.8)
"""The first cycle where the changed gain changes an output."""

pytestmark = pytest.mark.usefixtures("outside_ci", "wide_plain_console")


@pytest.fixture
def spec(tmp_path: Path, record_probe: RecordFn, beatlog: Beatlog) -> Path:
    """A spec whose intended change (near reacts earlier) has an approved baseline."""
    spec = write_spec(tmp_path / "specs", "avoid-pole", record_probe(300), CHANGED)
    assert beatlog("test", "--update", spec).code == 1
    assert beatlog("approve", spec).code == 0
    return spec


def test_update_and_approve_pin_the_outputs(spec: Path) -> None:
    baseline = read_baseline(expected_path(spec))
    assert baseline.whole.outputs is not None
    assert {traced.field for traced in baseline.whole.outputs} == {"speed", "time"}
    lines = expected_path(spec).read_text(encoding="utf-8").splitlines()
    assert lines[0] == "# beatlog expected departures from the recording, format 7"
    # Only where the outputs depart from the recording, and where they follow it again.
    assert lines[4:9] == [
        "      21     0.660  open loop",
        '      21     0.660  "arbiter": "dice" -> "near"',
        '      21     0.660  "near": "far" -> "near"',
        '      21     0.660  output "speed" = 0.0',
        '      21     0.660  output "time" absent',
    ]
    assert lines[9:14] == [
        "      26     0.810  no state changes",
        '      75     2.280  "dice": "odd" -> "even"',
        '      80     2.430  "arbiter": "near" -> "dice"',
        '      80     2.430  "near": "near" -> "far"',
        '      80     2.430  output "speed" as recorded',
    ]


def test_a_changed_motor_gain_fails_against_the_approved_baseline(
    spec: Path, beatlog: Beatlog
) -> None:
    assert beatlog("test", spec).code == 0
    write_spec(spec.parent, "avoid-pole", spec.parent.parent / "probe.beatlog", GEARED)

    run = beatlog("test", spec)

    assert run.code == 1
    assert f"first divergence: cycle {GAIN_CYCLE}, t = 0.360 s, outputs" in whole_lines(run.out)
    assert "outputs differ from the approved baseline" in whole_lines(run.out)
    assert table_row(run.out, "speed = 0.5") == ["speed = 0.5", "speed = 0.55"]


def test_review_shows_the_output_changes_of_the_changed_cycles(
    spec: Path, beatlog: Beatlog, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("sys.stdin", io.StringIO(""))  # no terminal, nothing piped
    write_spec(spec.parent, "avoid-pole", spec.parent.parent / "probe.beatlog", GEARED)
    assert beatlog("test", "--update", spec).code == 1

    run = beatlog("review", spec)

    assert run.code == 0
    lines = run.out.splitlines()
    approved = expected_path(spec).name
    assert lines[1:9] == [
        f"178 state and output changes approved ({approved}) → 184 pending: 0 state changes "
        "lost, 0 new, 0 moved",
        f"open loop since cycle {GAIN_CYCLE} (0.360 s): closed loop for {GAIN_CYCLE} of 300 "
        f"cycles ({GAIN_CYCLE * 100 // 300} %)",
        f"--- approved ({approved})",
        "+++ pending",
        "@@ -15,2 +15,3 @@",
        '       10     0.330  output "time" = 0.33001',
        f'+{GAIN_CYCLE:>8}     0.360  output "speed" = 0.55',
        f'{GAIN_CYCLE:>9}     0.360  output "time" = 0.360012',
    ]
    changed = [line for line in lines if line[:1] in "+-" and line[:3] not in ("+++", "---")]
    assert all('output "speed"' in line for line in changed)  # only the gain changed
    assert len(lines) < 80  # changed cycles with a line of context, not the whole file


def test_a_format_1_baseline_is_upgraded_to_judge_outputs_against_the_recording(
    spec: Path, beatlog: Beatlog
) -> None:
    path = expected_path(spec)
    lines = path.read_text(encoding="utf-8").splitlines()
    log = spec.parent.parent / "probe.beatlog"
    approved = read_baseline(path).whole
    trace = whole_trace(approved, log)
    path.write_text(  # a format 1 file held the whole trace of state changes, and no outputs
        "\n".join(["# beatlog expected state changes, format 1", *lines[1:3]])
        + "\n"
        + "\n".join(format_lines(trace.changes))
        + "\n",
        encoding="utf-8",
    )

    refused = beatlog("test", spec)
    upgraded = beatlog("upgrade-baselines", spec.parent)

    assert refused.code == 2
    assert refused.err.count("\n") == 1
    assert refused.err.endswith(
        f": {path}: a format 1 baseline: "
        f"run 'beatlog upgrade-baselines {path}' to rewrite it in format 7\n"
    )
    assert (upgraded.code, upgraded.out) == (0, f"upgraded {path}: format 1 -> 7\n")
    upgrade = read_baseline(path).whole
    assert (upgrade.changes, upgrade.quiet, upgrade.outputs) == (
        approved.changes,
        approved.quiet,
        (),
    )
    run = beatlog("test", "--update", spec)
    assert run.code == 1
    assert "outputs differ from the approved baseline" in whole_lines(run.out)
    assert beatlog("approve", spec).code == 0
    assert read_baseline(path).whole.outputs == approved.outputs
    assert beatlog("test", spec).code == 0


def test_a_format_4_baseline_of_the_whole_trace_upgrades_to_the_same_departures(
    spec: Path, beatlog: Beatlog
) -> None:
    path = expected_path(spec)
    departures = path.read_text(encoding="utf-8")
    approved = read_baseline(path).whole
    trace = whole_trace(approved, spec.parent.parent / "probe.beatlog")
    lines = format_lines(trace.changes, trace.outputs, open_loop=trace.baseline.open_loop)
    path.write_text(
        "\n".join(
            [
                "# beatlog expected state changes, outputs, robot states and draws, format 4",
                *departures.splitlines()[1:3],
                *lines,
            ]
        )
        + "\n",
        encoding="utf-8",
    )
    assert len(lines) > len(departures.splitlines())  # the whole trace

    run = beatlog("upgrade-baselines", path)

    assert (run.code, run.out) == (0, f"upgraded {path}: format 4 -> 7\n")
    assert read_baseline(path).whole == approved
    assert path.read_text(encoding="utf-8") == departures
    assert beatlog("test", spec).code == 0
    again = beatlog("upgrade-baselines", path)
    assert (again.code, again.out) == (0, "no baseline of an older format\n")
    assert path.read_text(encoding="utf-8") == departures
