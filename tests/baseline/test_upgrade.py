"""Baselines of older formats are rewritten in format 7 by one command, reading to the
departures they stood for; a format 7 one is left as it is, damage is still refused,
and robot states pinned the old ways are left to re-approve."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.analysis.trace import recorded_outputs, recorded_trace
from beatlog.baseline.file import expected_path, log_digest, pending_path, read_baseline
from beatlog.baseline.upgrade import Upgraded, upgrade_baseline, upgrade_baselines
from beatlog.baseline.write import COLUMNS, format_lines, write_baseline
from beatlog.errors import BaselineError
from beatlog.replay.approved_states import ApprovedStates
from beatlog.replay.baseline import (
    ABSENT,
    AS_RECORDED,
    Baseline,
    TracedOutput,
    TracedStateChange,
)
from beatlog.replay.verdict import StateChange
from tests.conftest import RecordFn
from tests.factories import rebuilt_states, speed_state
from tests.specs import BASELINE_MAGIC, baseline_file

DEPARTURES = Baseline(
    (TracedStateChange(12, 360_000_000, StateChange("avoid", "off", "turning")),),
    (
        TracedOutput(12, 360_000_000, "speed", 0.0),
        TracedOutput(13, 390_000_000, "turn", ABSENT),
        TracedOutput(20, 600_000_000, "speed", AS_RECORDED),
    ),
    open_loop=(12, 360_000_000),
    quiet=((15, 450_000_000),),
)


def written(path: Path, log: Path, baseline: Baseline, version: int) -> Path:
    """``baseline`` written in format 7, its first line then that of ``version``."""
    write_baseline(
        path, spec_name="a", log_name=log.name, digest=log_digest(log), baseline=baseline
    )
    lines = path.read_text(encoding="utf-8").splitlines()
    path.write_text("\n".join([BASELINE_MAGIC[version], *lines[1:]]) + "\n", encoding="utf-8")
    return path


@pytest.fixture
def log(tmp_path: Path) -> Path:
    path = tmp_path / "a.beatlog"
    path.write_bytes(b"a recording")
    return path


@pytest.mark.parametrize("version", [5, 6])
def test_a_format_5_or_6_baseline_is_rewritten_in_format_7_once(
    tmp_path: Path, log: Path, version: int
) -> None:
    path = written(tmp_path / "a.dtc.expected", log, DEPARTURES, version)
    current = written(tmp_path / "b.dtc.expected", log, DEPARTURES, 7).read_text(encoding="utf-8")

    assert upgrade_baseline(path) == Upgraded(path, version)
    assert read_baseline(path).whole == DEPARTURES
    assert path.read_text(encoding="utf-8") == current
    assert upgrade_baseline(path) is None
    assert path.read_text(encoding="utf-8") == current


def test_every_baseline_under_a_folder_or_beside_a_spec_is_upgraded(
    tmp_path: Path, log: Path
) -> None:
    approved = written(expected_path(tmp_path / "a.dtc.toml"), log, DEPARTURES, 5)
    pending = written(pending_path(tmp_path / "a.dtc.toml"), log, DEPARTURES, 5)
    (tmp_path / "deep").mkdir()
    deep = written(tmp_path / "deep" / "b.dtc.expected", log, DEPARTURES, 5)
    current = written(tmp_path / "deep" / "c.dtc.pending", log, DEPARTURES, 7)

    assert upgrade_baselines([tmp_path / "a.dtc.toml"]) == [
        Upgraded(approved, 5),
        Upgraded(pending, 5),
    ]
    assert upgrade_baselines([tmp_path]) == [Upgraded(deep, 5)]
    assert read_baseline(current).whole == DEPARTURES


def test_damage_in_an_older_baseline_is_refused_naming_the_file_and_line(
    tmp_path: Path, log: Path
) -> None:
    path = written(tmp_path / "a.dtc.expected", log, DEPARTURES, 5)
    text = path.read_text(encoding="utf-8").replace('"turning"', '"turning" 2')
    path.write_text(text, encoding="utf-8")

    with pytest.raises(BaselineError) as raised:
        upgrade_baseline(path)

    assert str(raised.value) == f"{path}: line 6: unexpected ' 2' after the state"
    assert path.read_text(encoding="utf-8") == text
    assert sorted(tmp_path.iterdir()) == [log, path]


def test_damage_in_a_current_baseline_is_still_refused(tmp_path: Path) -> None:
    path = baseline_file(tmp_path, 7, '      12     0.360  "avoid": "off" => "turning"')

    with pytest.raises(BaselineError, match="line 3: expected '->' at column"):
        upgrade_baseline(path)


def test_a_foreign_file_is_no_baseline_to_upgrade(tmp_path: Path) -> None:
    path = tmp_path / "a.dtc.expected"
    path.write_text("cycle,behavior\n", encoding="utf-8")

    with pytest.raises(BaselineError, match="not a beatlog baseline"):
        upgrade_baseline(path)


@pytest.mark.parametrize("version", [4, 5])
def test_robot_states_pinned_by_blake2b_are_left_to_re_approve(
    tmp_path: Path, log: Path, version: int
) -> None:
    states = {cycle: speed_state(cycle) for cycle in (12, 13, 16)}
    approved = ApprovedStates.from_rebuilt(rebuilt_states(states))
    path = baseline_file(
        tmp_path, version, COLUMNS, *format_lines((), (), approved_states=approved)
    )
    text = path.read_text(encoding="utf-8")

    with pytest.raises(BaselineError, match=f"pinned as format {version} pinned them: re-approve"):
        upgrade_baseline(path)
    assert path.read_text(encoding="utf-8") == text


def test_a_format_4_baseline_as_recorded_upgrades_to_no_departures(tmp_path: Path) -> None:
    path = baseline_file(tmp_path, 4, "state changes and outputs as recorded", spec=True)

    assert upgrade_baseline(path) == Upgraded(path, 4)
    assert read_baseline(path).whole.as_recorded


def test_a_format_4_baseline_as_recorded_that_pins_a_change_is_refused(tmp_path: Path) -> None:
    as_recorded = "state changes and outputs as recorded"
    change = '      3     0.090  "avoid": "idle" -> "turning"'
    path = baseline_file(tmp_path, 4, as_recorded, change, spec=True)

    with pytest.raises(BaselineError, match="as recorded', yet it pins state changes"):
        upgrade_baseline(path)


def test_a_whole_trace_upgrades_to_where_it_departs_from_the_recording(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(40, name="a.beatlog")
    recorded, outputs = recorded_trace(log), recorded_outputs(log)
    gone, changed = recorded[0].cycle, recorded[-1]
    other = changed._replace(change=changed.change._replace(after="far"))
    trace = [c for c in recorded if c.cycle != gone and c != changed] + [other]
    first = outputs[0]
    whole = [first._replace(value="held"), *outputs[1:]]
    again = next(o for o in outputs[1:] if o.field == first.field)
    path = tmp_path / "a.dtc.expected"
    path.write_text(
        "\n".join(
            [
                BASELINE_MAGIC[2],
                f"# log a.beatlog sha256 {log_digest(log)}",
                *format_lines(trace, whole),
            ]
        )
        + "\n",
        encoding="utf-8",
    )

    assert upgrade_baseline(path) == Upgraded(path, 2)
    read = read_baseline(path).whole
    assert [cycle for cycle, _ in read.quiet] == [gone]
    assert [(c.cycle, c.change) for c in read.changes] == [
        (c.cycle, c.change) for c in trace if c.cycle == changed.cycle
    ]
    assert [(o.cycle, o.field, o.value) for o in read.outputs or ()] == [
        (first.cycle, first.field, "held"),
        (again.cycle, first.field, AS_RECORDED),
    ]
    assert read.open_loop is not None
    assert read.open_loop[0] == min(first.cycle, gone)


def test_a_whole_trace_needs_its_own_recording_beside_it(tmp_path: Path) -> None:
    path = baseline_file(tmp_path, 4, '      12     0.360  "avoid": "off" -> "turning"')

    with pytest.raises(BaselineError, match=r"its recording .*a\.beatlog is not as it was"):
        upgrade_baseline(path)


def test_robot_states_pinned_by_format_6_digests_are_kept(tmp_path: Path, log: Path) -> None:
    states = {cycle: speed_state(cycle) for cycle in (12, 13, 16)}
    pinned = Baseline((), approved_states=ApprovedStates.from_rebuilt(rebuilt_states(states)))
    path = written(tmp_path / "a.dtc.expected", log, pinned, 6)

    assert upgrade_baseline(path) == Upgraded(path, 6)
    assert read_baseline(path).whole == pinned
