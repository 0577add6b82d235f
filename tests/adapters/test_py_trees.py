"""A py_trees tree records and replays: stable node ids, robot time, credited random
numbers, a fresh blackboard, and bugs caught at the node that changed."""

from __future__ import annotations

import json
import random as stdlib_random
import subprocess
import sys
from pathlib import Path

import py_trees
import pytest
from py_trees.common import Status

from beatlog import LiveHeartbeat, Recorder, replay
from beatlog.adapters.py_trees import TreeSystem, context, random
from beatlog.analysis.trace import recorded_trace, replayed_trace
from beatlog.model.cycle import CycleExecutor
from beatlog.model.random import RecordingRandom
from beatlog_examples.trees import SUITE_DIR, PatrolState, system
from beatlog_examples.trees.patrol import CHANGES, Tuning, changed_system
from beatlog_examples.trees.record import SCENARIOS, Scenario, Yard, record
from tests.conftest import PERIOD_NS

PATROL_IDS = [
    "Rover",
    "Rover/Sense",
    "Rover/Sense/Path",
    "Rover/Tasks",
    "Rover/Tasks/Charge",
    "Rover/Tasks/Charge/Battery low?",
    "Rover/Tasks/Charge/Dock in time",
    "Rover/Tasks/Charge/Dock in time/Dock",
    "Rover/Tasks/Charge/Charging",
    "Rover/Tasks/Patrol",
    "Rover/Tasks/Patrol/Pick waypoint",
    "Rover/Tasks/Patrol/Go",
    "Rover/Tasks/Patrol/Go/Wait for path",
    "Rover/Tasks/Patrol/Go/Wait for path/Path clear?",
    "Rover/Tasks/Patrol/Go/Drive",
    "Rover/Tasks/Patrol/Look around",
    "Rover/Tasks/Patrol/Look around/Sniff",
    "Rover/Tasks/Patrol/Pause",
    "blackboard/waypoint",
    "blackboard/path_clear",
]


def test_every_node_is_a_behavior_named_by_its_path_in_tree_order() -> None:
    assert list(system().behaviors) == PATROL_IDS
    assert {behavior.state for behavior in system().behaviors.values()} == {"INVALID", None}


def test_the_ids_are_the_same_in_another_process() -> None:
    script = (
        "import json; from beatlog_examples.trees import system; "
        "print(json.dumps(list(system().behaviors)))"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True
    )
    assert json.loads(done.stdout) == PATROL_IDS


def test_a_log_recorded_here_replays_in_another_process(tmp_path: Path) -> None:
    log = tmp_path / "patrol.beatlog"
    record(log, SCENARIOS[0])
    script = (
        "import sys, beatlog; "
        "result = beatlog.replay(sys.argv[1], 'beatlog_examples.trees:system'); "
        "print(result.ok, result.cycles)"
    )
    done = subprocess.run(
        [sys.executable, "-c", script, str(log)], capture_output=True, text=True, check=True
    )
    assert done.stdout.split() == ["True", str(replay(log, system()).cycles)]


def leaf(name: str) -> py_trees.behaviour.Behaviour:
    return py_trees.behaviours.Success(name)


def test_a_built_tree_in_place_of_its_builder_is_refused_saying_which_it_takes() -> None:
    built = py_trees.composites.Sequence("Rover", memory=False, children=[leaf("Wait")])

    with pytest.raises(TypeError) as raised:
        TreeSystem(built, robot_state=PatrolState)  # type: ignore[arg-type]  # the slip

    assert str(raised.value) == (
        "TreeSystem takes the function that builds the tree, not the tree 'Rover' built: "
        "each replay builds its own (TreeSystem(tree, ...))"
    )


def test_siblings_of_the_same_name_are_numbered_and_separators_escaped() -> None:
    def build() -> py_trees.behaviour.Behaviour:
        return py_trees.composites.Sequence(
            "root",
            memory=False,
            children=[leaf("Wait"), leaf("Wait"), leaf("Wait#2"), leaf("a/b"), leaf("Wait")],
        )

    names = list(TreeSystem(build, robot_state=PatrolState).behaviors)
    assert names == [
        "root",
        "root/Wait",
        "root/Wait#2",
        "root/Wait%232",
        "root/a%2Fb",
        "root/Wait#3",
    ]


def test_the_patrol_tree_records_and_replays_to_pass_twice_identically(tmp_path: Path) -> None:
    log = tmp_path / "low-battery.beatlog"
    record(log, SCENARIOS[1])
    first, second = replay(log, system()), replay(log, system())
    assert (first.ok, first.divergence, first.counts) == (
        True,
        None,
        {"cycles": 679, "state_changes": 96, "outputs": 636, "draws": 7, "samples": 0},
    )
    assert (second.ok, second.divergence, second.counts) == (
        True,
        None,
        {"cycles": 679, "state_changes": 96, "outputs": 636, "draws": 7, "samples": 0},
    )
    assert first.cycles == second.cycles == replay(log, system()).cycles
    recorded = tuple(recorded_trace(log))
    assert replayed_trace(log, system()).changes == recorded
    assert replayed_trace(log, system()).changes == recorded
    behaviors = {traced.change.behavior for traced in recorded}
    assert {"Rover/Tasks/Charge/Dock in time", "Rover/Tasks/Patrol/Pause"} <= behaviors


EXPECTED_NODE = {
    "selector reordered": "Rover/Tasks/Charge",
    "threshold changed": "Rover/Tasks/Charge",
    "decorator swapped": "Rover/Tasks/Patrol/Go/Wait for path",
}


@pytest.mark.parametrize("change", sorted(CHANGES))
def test_a_bug_in_the_tree_fails_at_the_node_that_acts_differently(change: str) -> None:
    logs = sorted(SUITE_DIR.glob("*.beatlog"))
    divergences = [replay(log, changed_system(change)).divergence for log in logs]
    first = next(divergence for divergence in divergences if divergence is not None)
    assert first.behavior == EXPECTED_NODE[change]
    assert first.message == "behavior state changes differ from the recording"


def test_the_threshold_bug_shows_the_check_that_no_longer_passes() -> None:
    divergence = replay(SUITE_DIR / "low-battery.beatlog", changed_system()).divergence
    assert divergence is not None
    changed = {change.behavior: change.after for change in divergence.expected}
    assert changed["Rover/Tasks/Charge/Battery low?"] == "SUCCESS"
    assert "Rover/Tasks/Charge/Battery low?" not in {c.behavior for c in divergence.actual}


def test_a_session_recorded_in_real_time_replays_without_waiting(tmp_path: Path) -> None:
    quick = Tuning(speed_m_s=60.0, pause_s=0.1)
    log = tmp_path / "live.beatlog"
    yard = Yard(Scenario("live", "", battery=0.9, duration_s=0.8, crossings=(), seed=1))
    heartbeat = LiveHeartbeat(10_000_000)
    with Recorder(log, system(quick), seed=1) as recorder:
        heartbeat.start()
        for _ in range(80):
            interval_ns = heartbeat.wait()
            yard.advance(recorder.step(interval_ns, yard.state()), interval_ns / 1e9)
    pauses = [t for t in recorded_trace(log) if t.change.behavior == "Rover/Tasks/Patrol/Pause"]
    assert any(t.change.after == "SUCCESS" for t in pauses)  # the Timer ran out in the session
    assert replay(log, system(quick)).ok


class Counter(py_trees.behaviour.Behaviour):
    """Counts its ticks on the blackboard, starting from what it finds there."""

    def __init__(self) -> None:
        super().__init__("Counter")
        self.bb = self.attach_blackboard_client()
        self.bb.register_key("count", access=py_trees.common.Access.WRITE)

    def update(self) -> Status:
        self.bb.count = self.bb.get("count") + 1 if self.bb.exists("count") else 1
        return Status.SUCCESS


def counting() -> TreeSystem[PatrolState]:
    return TreeSystem(Counter, robot_state=PatrolState, blackboard=["count"])


def test_the_blackboard_starts_empty_for_every_build(tmp_path: Path) -> None:
    log = tmp_path / "count.beatlog"
    with Recorder(log, counting()) as recorder:
        for _ in range(5):
            recorder.step(PERIOD_NS, PatrolState())
    assert py_trees.blackboard.Blackboard.get("/count") == 5
    fresh = counting()
    assert "/count" not in py_trees.blackboard.Blackboard.storage
    assert fresh.behaviors["blackboard/count"].state is None
    assert replay(log, fresh).ok


def test_the_robot_state_is_on_the_blackboard_during_the_tick() -> None:
    executor = CycleExecutor(system(), RecordingRandom(seed=3))
    executor.step(PERIOD_NS, PatrolState(obstacle=0.2))
    assert py_trees.blackboard.Blackboard.get("/robot_state.obstacle") == 0.2
    assert executor.system.behaviors["blackboard/path_clear"].state is False


def test_random_numbers_are_credited_to_the_node_that_drew_them() -> None:
    source = RecordingRandom(seed=3)
    executor = CycleExecutor(system(Tuning(speed_m_s=1e6, pause_s=1e6)), source)
    drawers: set[str] = set()
    for _ in range(20):
        executor.step(PERIOD_NS, PatrolState())
        drawers.update(executor.behavior_ids[draw.actor] for draw in source.take())
    assert drawers == {"Rover/Tasks/Patrol/Pick waypoint", "Rover/Tasks/Patrol/Look around/Sniff"}


def test_outside_a_tick_py_trees_keeps_the_global_random_module() -> None:
    sniff = py_trees.behaviours.ProbabilisticBehaviour("Sniff", weights=[1.0, 1.0, 1.0])
    stdlib_random.seed(5)
    expected = stdlib_random.choices(
        [Status.SUCCESS, Status.FAILURE, Status.RUNNING], [1.0, 1.0, 1.0]
    )
    stdlib_random.seed(5)
    sniff.tick_once()
    assert [sniff.status] == expected


def test_a_behaviour_asking_for_beatlogs_context_outside_a_tick_is_told_so() -> None:
    node = leaf("Lonely")
    with pytest.raises(RuntimeError, match="'Lonely' asked for beatlog's context outside"):
        context(node)
    with pytest.raises(RuntimeError):
        random(node)


def test_a_node_of_another_tree_has_no_random_numbers_here() -> None:
    stranger = leaf("Stranger")

    class Borrower(py_trees.behaviour.Behaviour):
        def update(self) -> Status:
            random(stranger).random()
            return Status.SUCCESS

    executor = CycleExecutor(
        TreeSystem(lambda: Borrower("Borrower"), robot_state=PatrolState), RecordingRandom(1)
    )
    with pytest.raises(ValueError, match="'Stranger' is not a node of this tree"):
        executor.step(PERIOD_NS, PatrolState())


def test_importing_beatlog_does_not_import_py_trees() -> None:
    script = "import sys, beatlog, beatlog.adapters; print('py_trees' in sys.modules)"
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True
    )
    assert done.stdout.strip() == "False"


def test_a_weighted_pick_in_a_tick_is_cpythons_on_the_random_source() -> None:
    picks: list[list[str]] = []

    class Picker(py_trees.behaviour.Behaviour):
        def update(self) -> Status:
            as_py_trees_sees_it = vars(py_trees.behaviours)["random"]
            picks.append(as_py_trees_sees_it.choices("abc", [1.0, 0.0, 3.0], k=4))
            with pytest.raises(ValueError, match="number of weights does not match"):
                as_py_trees_sees_it.choices("abc", [1.0])
            return Status.SUCCESS

    source = RecordingRandom(seed=8)
    executor = CycleExecutor(TreeSystem(lambda: Picker("Picker"), robot_state=PatrolState), source)
    executor.step(PERIOD_NS, PatrolState())

    draws = [draw.value for draw in source.take()]
    assert picks == [["a" if value * 4 < 1 else "c" for value in draws]]
