"""An intended perception change is re-baselined like a behavior change: ``--update``
pins the robot states perception now rebuilds (by digest, a few bytes a cycle) and what
the behaviors then do, ``review`` shows the runs of cycles and the fields that differ,
and the recording stays untouched. Format 3 baselines, which pinned field values,
still judge."""

from __future__ import annotations

import hashlib
import io
import json
from pathlib import Path

import pytest

from beatlog.analysis.trace import recorded_outputs, recorded_trace
from beatlog.baseline.file import expected_path, pending_path, read_baseline
from beatlog.baseline.write import format_lines
from tests.commands import Beatlog
from tests.conftest import distances
from tests.perceptions import (
    CHANGED,
    CHANGED_AGAIN,
    ONE_ULP,
    PERCEPTION,
    ULP_CYCLE,
    record_with_samples,
)
from tests.specs import write_spec
from tests.text import table_row, whole_lines

SHIFTED = "tests.perceptions:shifted_perception"
NUDGED = "tests.perceptions:nudged_perception"
LONG = sum(distance >= 0.8 for distance in distances(300))
"""The cycles in which the changed perception reads the range long."""
RUNS = [(0, 10), (90, 110), (190, 210), (290, 299)]
"""The runs of cycles in which it does."""

pytestmark = pytest.mark.usefixtures("outside_ci", "wide_plain_console")


@pytest.fixture
def log(tmp_path: Path) -> Path:
    return record_with_samples(tmp_path / "samples.beatlog")


@pytest.fixture
def approved(tmp_path: Path, log: Path, beatlog: Beatlog) -> Path:
    """A spec whose changed perception has an approved baseline."""
    spec = write_spec(tmp_path, "sensors", log, perception=CHANGED)
    assert beatlog("test", "--update", spec).code == 1
    assert beatlog("approve", spec).code == 0
    return spec


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_update_pins_the_rebuilt_robot_states_and_review_shows_them(
    tmp_path: Path, log: Path, beatlog: Beatlog, monkeypatch: pytest.MonkeyPatch
) -> None:
    recorded = _digest(log)
    spec = write_spec(tmp_path, "sensors", log, perception=CHANGED)
    assert beatlog("test", spec).code == 1

    update = beatlog("test", "--update", spec)
    assert update.code == 1
    assert "1 robot-state field rebuilt otherwise" not in update.out
    assert (
        f"pending {pending_path(spec)} (0 state changes lost, 0 new, 0 moved, 0 output changes, "
        "robot state rebuilt "
        f"otherwise in {LONG} cycles): review with beatlog review {spec}, accept with beatlog "
        f"approve {spec}"
    ) in whole_lines(update.out)
    approved = read_baseline(pending_path(spec)).whole.approved_states
    assert approved.cycles == LONG
    assert [(run.cycle, run.last, run.fields) for run in approved.runs] == [
        (first, last, ("distance",)) for first, last in RUNS
    ]
    assert approved.runs[0].first == {"distance": 1.1}

    waiting = pending_path(spec).read_bytes()
    monkeypatch.setattr("sys.stdin", io.StringIO("accept\n"))
    review = beatlog("review", spec)
    assert review.code == 0
    assert (
        'robot state "distance" rebuilt otherwise in cycles 0–10 (11 cycles), first: '
        '"distance" 1.0 → 1.1' in whole_lines(review.out)
    )
    assert (
        '+       0     0.030  robot_state otherwise in 0..10 (11 cycles): ["distance"], '
        'first {"distance": 1.1}' in whole_lines(review.out)
    )
    assert expected_path(spec).read_bytes() == waiting

    assert beatlog("test", spec).code == 0
    assert _digest(log) == recorded


def test_a_perception_that_changes_again_fails_against_the_baseline(
    tmp_path: Path, log: Path, beatlog: Beatlog, approved: Path
) -> None:
    again = beatlog("test", write_spec(tmp_path, "sensors", log, perception=CHANGED_AGAIN))
    assert again.code == 1
    assert (
        "the robot state rebuilt from the samples differs from the approved baseline by its "
        "digest; it differs from the recording in distance, the approved one in distance "
        "(cycles 0–10)" in whole_lines(again.out)
    )
    back = beatlog("test", write_spec(tmp_path, "sensors", log, perception=PERCEPTION))
    assert back.code == 1
    assert (
        "the robot state rebuilt from the samples differs from the approved baseline by its "
        "digest; it differs from the recording in no field, the approved one in distance "
        "(cycles 0–10)" in whole_lines(back.out)
    )
    # recorded and rebuilt alike, side by side
    assert table_row(back.out, "distance = 1.0") == ["distance = 1.0", "distance = 1.0"]


def test_a_one_ulp_change_of_one_field_in_one_cycle_fails_in_that_cycle(
    tmp_path: Path, log: Path, beatlog: Beatlog, approved: Path
) -> None:
    run = beatlog("test", write_spec(tmp_path, "sensors", log, perception=ONE_ULP))

    assert run.code == 1
    assert f"first divergence: cycle {ULP_CYCLE}, t = 2.880 s, perception" in whole_lines(run.out)
    assert (
        "the robot state rebuilt from the samples differs from the approved baseline by its "
        "digest; it differs from the recording in distance, the approved one in distance "
        "(cycles 90–110)" in whole_lines(run.out)
    )


def test_a_format_3_baseline_pinning_field_values_is_left_to_re_approve(
    log: Path, beatlog: Beatlog, approved: Path
) -> None:
    lines = expected_path(approved).read_text(encoding="utf-8").splitlines()
    fields = [
        f'{t:>8} {(t + 1) * 0.03:>9.3f}  robot_state "distance" = {json.dumps(d * 1.1)}'
        for t, d in enumerate(distances(300))
        if d >= 0.8
    ]
    comments = [line for line in lines[1:] if line.startswith("# ")]
    trace = format_lines(recorded_trace(log), recorded_outputs(log))  # format 3 held it all
    path = expected_path(approved)
    text = "\n".join(
        [
            "# beatlog expected state changes, outputs and robot states, format 3",
            *comments,
            *trace,
            *fields,
        ]
    )
    path.write_text(text + "\n", encoding="utf-8")

    run = beatlog("upgrade-baselines", approved)

    assert (run.code, run.out) == (2, "")
    assert run.err == (
        f"beatlog: error: {path}: its robot states are pinned as format 3 pinned them: "
        "re-approve it from its recording ('beatlog test --update', then 'beatlog approve')\n"
    )
    assert path.read_text(encoding="utf-8") == text + "\n"


def test_a_retuned_perception_pins_a_long_log_in_a_few_bytes_a_cycle(
    tmp_path: Path, beatlog: Beatlog
) -> None:
    log = record_with_samples(tmp_path / "long.beatlog", 1000)
    spec = write_spec(tmp_path, "long", log, perception=NUDGED)
    assert beatlog("test", "--update", spec).code == 1

    lines = pending_path(spec).read_text(encoding="utf-8").splitlines(keepends=True)
    pinned = [line for line in lines if "robot_state" in line and not line.startswith("#")]

    assert read_baseline(pending_path(spec)).whole.approved_states.cycles == 1000
    assert len(pinned) == 1 + 16  # a run of 1,000 cycles: 64 a line
    assert sum(len(line.encode()) for line in pinned) <= 3.2 * 1000


def test_the_state_changes_that_follow_a_perception_change_are_pinned_too(
    tmp_path: Path, log: Path, beatlog: Beatlog, monkeypatch: pytest.MonkeyPatch
) -> None:
    spec = write_spec(tmp_path, "sensors", log, perception=SHIFTED)
    assert beatlog("test", "--update", spec).code == 1

    monkeypatch.setattr("sys.stdin", io.StringIO("accept\n"))
    review = beatlog("review", spec)
    assert (
        'robot state "distance" rebuilt otherwise in cycles 0–299 (300 cycles), first: "distance" '
        "1.0 → 0.95" in whole_lines(review.out)
    )
    changes = {line[0] for line in review.out.splitlines() if '"near": "far" -> "near"' in line}
    assert changes == {"-", "+"}  # near sees the pole in other cycles

    assert beatlog("test", spec).code == 0


@pytest.mark.parametrize("factory", ["broken_perception", "dict_perception"])
def test_a_perception_that_raises_or_builds_no_robot_state_is_not_re_baselined(
    tmp_path: Path, log: Path, beatlog: Beatlog, factory: str
) -> None:
    spec = write_spec(tmp_path, "sensors", log, perception=f"tests.perceptions:{factory}")
    update = beatlog("test", "--update", spec)
    assert update.code == 1
    assert (
        "not updated sensors: perception raised or built no robot state: a baseline pins what "
        "perception rebuilds; fix it first"
    ) in whole_lines(update.out)
    assert not pending_path(spec).exists()


def test_a_perception_change_the_behaviors_do_not_notice_pins_no_copy_of_the_trace(
    tmp_path: Path, log: Path, beatlog: Beatlog, approved: Path
) -> None:
    lines = expected_path(approved).read_text(encoding="utf-8").splitlines()
    passed = beatlog("test", approved).code
    planted = write_spec(tmp_path, "sensors", log, "tests.systems:probe_system_changed_again",
                         perception=CHANGED)  # fmt: skip

    assert passed == 0
    pinned = [line for line in lines if not line.startswith("#")]
    assert [line for line in pinned if "robot_state " not in line] == []  # no open loop
    run = beatlog("test", planted)
    assert run.code == 1
    assert "behavior state changes differ from the recording" in whole_lines(run.out)
