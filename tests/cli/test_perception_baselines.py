"""An intended perception change is re-baselined like a behavior change: ``--update``
pins the robot states perception now rebuilds and what the behaviors then do,
``review`` shows the robot-state fields and state changes that differ, and the
recording stays untouched."""

from __future__ import annotations

import hashlib
import io
from pathlib import Path

import pytest

from beatlog.suite.baseline import expected_path, pending_path, read_baseline
from tests.commands import Beatlog
from tests.conftest import distances
from tests.perceptions import CHANGED, CHANGED_AGAIN, PERCEPTION, record_with_samples
from tests.specs import write_spec

SHIFTED = "tests.perceptions:shifted_perception"
LONG = sum(distance >= 0.8 for distance in distances(300))
"""The cycles in which the changed perception reads the range long."""

pytestmark = pytest.mark.usefixtures("outside_ci", "wide_plain_console")


@pytest.fixture
def log(tmp_path: Path) -> Path:
    return record_with_samples(tmp_path / "samples.beatlog")


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
    assert f"robot state rebuilt otherwise in {LONG} cycles): review with" in update.out
    pinned = read_baseline(pending_path(spec)).robot_states
    assert len(pinned) == LONG
    assert pinned[0].field == "distance"
    assert pinned[0].value == pytest.approx(1.1)

    monkeypatch.setattr("sys.stdin", io.StringIO("accept\n"))
    review = beatlog("review", spec)
    assert review.code == 0
    assert (
        f'robot state "distance" rebuilt otherwise in {LONG} cycles, first in cycle 0: '
        "1.0 → 1.1" in review.out
    )
    assert '+       0     0.030  robot_state "distance" = 1.1' in review.out
    assert expected_path(spec).exists()

    assert beatlog("test", spec).code == 0
    assert _digest(log) == recorded


def test_a_perception_that_changes_again_fails_against_the_baseline(
    tmp_path: Path, log: Path, beatlog: Beatlog
) -> None:
    spec = write_spec(tmp_path, "sensors", log, perception=CHANGED)
    assert beatlog("test", "--update", spec).code == 1
    assert beatlog("approve", spec).code == 0

    again = beatlog("test", write_spec(tmp_path, "sensors", log, perception=CHANGED_AGAIN))
    assert again.code == 1
    assert "differs from the approved baseline in distance" in again.out
    back = beatlog("test", write_spec(tmp_path, "sensors", log, perception=PERCEPTION))
    assert back.code == 1
    assert "differs from the approved baseline in distance" in back.out


def test_the_state_changes_that_follow_a_perception_change_are_pinned_too(
    tmp_path: Path, log: Path, beatlog: Beatlog, monkeypatch: pytest.MonkeyPatch
) -> None:
    spec = write_spec(tmp_path, "sensors", log, perception=SHIFTED)
    assert beatlog("test", "--update", spec).code == 1

    monkeypatch.setattr("sys.stdin", io.StringIO("accept\n"))
    review = beatlog("review", spec)
    assert 'robot state "distance" rebuilt otherwise in 300 cycles' in review.out
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
    assert "not updated sensors: perception raised or built no robot state" in update.out
    assert not pending_path(spec).exists()
