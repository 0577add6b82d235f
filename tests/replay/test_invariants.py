"""Invariants checked in every replayed cycle: the first that does not hold is the
verdict's divergence, unless an earlier cycle diverged; their own failures are the
DTC's, never beatlog's; only replays with invariants pay for every cycle's outcome."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.errors import SystemLoadError
from beatlog.model.invariant import Cycle
from beatlog.replay.core import Replayer
from beatlog.replay.judge import replay
from beatlog.replay.verdict import DivergenceKind, StateChange
from tests.conftest import Probe, RecordFn, distances, probe_system, probe_system_changed
from tests.specs import FIRST_CHANGED_CYCLE

CLOSE = 0.3
FIRST_CLOSE = next(t for t, d in enumerate(distances(300)) if d <= CLOSE)
"""The first cycle of a probe log whose distance is at most :data:`CLOSE`."""


@pytest.fixture
def log(record_probe: RecordFn) -> Path:
    return record_probe(300)


def stops_when_near(cycle: Cycle) -> None:
    """Holds: the probe stops wherever its near behavior is near."""
    if cycle.states["near"] == "near":
        assert cycle.outputs["speed"] == 0.0


def never_close(cycle: Cycle) -> None:
    """Does not hold from :data:`FIRST_CLOSE` on."""
    state = cycle.robot_state
    assert isinstance(state, Probe)
    if state.distance <= CLOSE:  # raised as a user's plain assert raises it, not rewritten
        raise AssertionError(f"{state.distance} m from the pole")


def far_enough(cycle: Cycle) -> bool:
    return bool(cycle.robot_state.distance > CLOSE)


def divides_by_the_distance(cycle: Cycle) -> None:
    1 / (cycle.robot_state.distance - distances(300)[FIRST_CLOSE])


class Patience:
    """Holds until it has seen :data:`FIRST_CLOSE` cycles, counting in its own state."""

    def __init__(self) -> None:
        self.seen = 0

    def __call__(self, cycle: Cycle) -> None:
        self.seen += 1
        if self.seen > FIRST_CLOSE:
            raise AssertionError("out of patience")


def test_invariants_that_hold_leave_the_verdict_as_it_was(log: Path) -> None:
    plain = replay(log, probe_system())

    checked = replay(log, probe_system(), invariants=[stops_when_near])

    assert (checked.ok, checked.counts) == (True, plain.counts)


def test_an_assertion_that_fails_is_an_invariant_divergence_in_its_cycle(log: Path) -> None:
    result = replay(log, probe_system(), invariants=[stops_when_near, never_close])

    divergence = result.divergence
    assert divergence is not None
    assert (divergence.kind, divergence.cycle, divergence.invariant) == (
        DivergenceKind.INVARIANT,
        FIRST_CLOSE,
        "never_close",
    )
    assert divergence.message == (
        f"invariant never_close does not hold: {distances(300)[FIRST_CLOSE]} m from the pole"
    )
    assert result.cycles == FIRST_CLOSE + 1


def test_the_divergence_holds_the_values_the_invariant_saw(log: Path) -> None:
    divergence = replay(log, probe_system(), invariants=[never_close]).divergence

    assert divergence is not None
    assert divergence.robot_state == {"distance": distances(300)[FIRST_CLOSE], "reading": 0.0}
    assert divergence.states == {"arbiter": "near", "near": "near", "dice": "even"}
    assert divergence.actual_outputs == {"speed": 0.0}
    assert divergence.time_ns > 0


def test_an_invariant_that_returns_false_does_not_hold(log: Path) -> None:
    divergence = replay(log, probe_system(), invariants=[far_enough]).divergence

    assert divergence is not None
    assert (divergence.cycle, divergence.message) == (
        FIRST_CLOSE,
        "invariant far_enough does not hold: it returned False",
    )


def test_an_invariant_that_raises_fails_the_replay_naming_it_and_its_exception(
    log: Path,
) -> None:
    divergence = replay(log, probe_system(), invariants=[divides_by_the_distance]).divergence

    assert divergence is not None
    assert (divergence.kind, divergence.cycle) == (DivergenceKind.INVARIANT, FIRST_CLOSE)
    assert divergence.message == (
        "invariant divides_by_the_distance raised ZeroDivisionError: float division by zero"
    )
    assert divergence.traceback is not None
    assert "divides_by_the_distance" in divergence.traceback


def test_a_class_is_an_invariant_instantiated_afresh_for_each_replay(log: Path) -> None:
    first = replay(log, probe_system(), invariants=[Patience]).divergence
    second = replay(log, probe_system(), invariants=[Patience]).divergence

    assert first is not None
    assert second is not None
    assert (first.cycle, second.cycle) == (FIRST_CLOSE, FIRST_CLOSE)
    assert first.message == "invariant Patience does not hold: out of patience"


def test_an_earlier_divergence_wins_over_a_later_violation(log: Path) -> None:
    assert FIRST_CHANGED_CYCLE < FIRST_CLOSE

    divergence = replay(log, probe_system_changed(), invariants=[never_close]).divergence

    assert divergence is not None
    assert (divergence.kind, divergence.cycle) == (
        DivergenceKind.STATE_CHANGES,
        FIRST_CHANGED_CYCLE,
    )


def test_an_earlier_violation_wins_over_a_later_divergence(log: Path) -> None:
    def never_seen(cycle: Cycle) -> None:
        assert cycle.cycle < FIRST_CHANGED_CYCLE - 1

    divergence = replay(log, probe_system_changed(), invariants=[never_seen]).divergence

    assert divergence is not None
    assert (divergence.kind, divergence.cycle) == (
        DivergenceKind.INVARIANT,
        FIRST_CHANGED_CYCLE - 1,
    )


def test_in_a_cycle_that_also_differs_the_violation_is_the_headline(log: Path) -> None:
    def near_only_when_close(cycle: Cycle) -> None:
        if cycle.states["near"] == "near" and cycle.robot_state.distance >= 0.5:
            raise AssertionError("near too soon")

    divergence = replay(log, probe_system_changed(), invariants=[near_only_when_close]).divergence

    assert divergence is not None
    assert (divergence.kind, divergence.cycle) == (DivergenceKind.INVARIANT, FIRST_CHANGED_CYCLE)
    assert divergence.expected != divergence.actual  # the difference is shown beside it


def test_keeping_going_counts_every_cycle_that_does_not_hold(log: Path) -> None:
    result = replay(log, probe_system(), invariants=[never_close], keep_going=True)

    assert result.divergence is not None
    assert result.divergence.cycle == FIRST_CLOSE
    assert result.divergent_cycles == sum(d <= CLOSE for d in distances(300))
    assert result.cycles == 300


def test_the_reproduce_command_names_the_invariants_given_by_reference(log: Path) -> None:
    result = replay(
        log,
        "tests.conftest:probe_system",
        invariants=["tests.replay.test_invariants:never_close", stops_when_near],
        explain=False,
    )

    assert result.reproduce.endswith(" --invariants tests.replay.test_invariants:never_close")


def test_a_cycle_gives_the_invariants_what_it_had(log: Path) -> None:
    seen: list[Cycle] = []

    replay(log, probe_system(), invariants=[seen.append])

    first_near = next(cycle for cycle in seen if cycle.changes)
    assert [cycle.cycle for cycle in seen] == list(range(300))
    assert seen[1].dt_ns == seen[1].time_ns - seen[0].time_ns
    assert seen[0].draws[0].behavior == "dice"
    assert StateChange("near", "far", "near") in first_near.changes or first_near.changes


def test_only_a_replay_with_invariants_builds_the_outcome_of_every_cycle(
    log: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    built: list[int] = []
    outcome = Replayer.outcome

    def counted(replayer: Replayer):  # type: ignore[no-untyped-def]
        built.append(1)
        return outcome(replayer)

    monkeypatch.setattr(Replayer, "outcome", counted)

    replay(log, probe_system())
    without = len(built)
    replay(log, probe_system(), invariants=[stops_when_near])

    assert (without, len(built) - without) == (0, 300)


def test_an_invariant_that_does_not_import_is_a_load_error(log: Path) -> None:
    with pytest.raises(SystemLoadError, match="has no nothing"):
        replay(log, probe_system(), invariants=["tests.conftest:nothing"])
