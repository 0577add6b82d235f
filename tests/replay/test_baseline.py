"""The baseline as replay judges against it: whole in memory, or read a part at a time."""

from __future__ import annotations

from beatlog.replay.baseline import ABSENT, Baseline, TracedOutput, TracedStateChange
from beatlog.replay.verdict import StateChange

CHANGES = (
    TracedStateChange(1, 30, StateChange("avoid", "idle", "turning")),
    TracedStateChange(4, 120, StateChange("wander", "walk", "sit")),
)
OUTPUTS = (
    TracedOutput(0, 30, "speed", 0.5),
    TracedOutput(0, 30, "turn", 1),
    TracedOutput(7, 240, "turn", ABSENT),
    TracedOutput(9, 300, "speed", 0.25),
)


def test_a_baseline_gives_every_output_of_the_cycles_where_one_changes() -> None:
    assert list(Baseline((), OUTPUTS).outputs_by_cycle()) == [
        (0, {"speed": 0.5, "turn": 1}),
        (7, {"speed": 0.5}),
        (9, {"speed": 0.25}),
    ]


def test_a_baseline_as_replay_reads_it_is_its_lines_in_one_part() -> None:
    baseline = Baseline(CHANGES, OUTPUTS, open_loop=(0, 30), quiet=((6, 180),))

    stream = baseline.stream()
    (part,) = stream.parts()

    assert (part.changes, part.outputs, part.quiet) == (CHANGES, OUTPUTS, ((6, 180),))
    assert (stream.departs, stream.pinned, stream.open_loop) == (True, False, (0, 30))
    assert stream.behaviors == ("avoid", "wander")
    assert part.last == 9


def test_a_baseline_of_robot_states_or_draws_alone_keeps_the_recorded_changes() -> None:
    assert Baseline(()).as_recorded
    assert Baseline(()).changes_override() is None
    assert Baseline(CHANGES, quiet=((6, 180),)).changes_override() == {
        1: [CHANGES[0].change],
        4: [CHANGES[1].change],
        6: [],
    }
    assert not Baseline(()).stream().departs
