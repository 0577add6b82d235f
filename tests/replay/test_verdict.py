"""The verdict types: what a replay gave, read by reports and people, and the one
builder of the ``reproduce:`` command lines they print."""

from __future__ import annotations

import dataclasses
import shlex
from pathlib import Path

import pytest

from beatlog.log.reader import LogStatus
from beatlog.replay.verdict import (
    Checked,
    ContextRow,
    Divergence,
    DivergenceKind,
    RandomDraw,
    ReplayResult,
    StateChange,
    reproduce_command,
)


def result(**changes: object) -> ReplayResult:
    """A passing replay of 300 cycles, 9 s of robot time in 0.5 s, that checked 12 state
    changes, 40 outputs and 9 draws; ``changes`` replace fields."""
    passed = ReplayResult(
        log=Path("probe.beatlog"),
        ok=True,
        cycles=300,
        checked=Checked(state_changes=12, outputs=40, draws=9),
        robot_time_ns=9_000_000_000,
        wall_time_s=0.5,
        status=LogStatus(complete=True, cycles=300),
        divergence=None,
        divergent_cycles=0,
        reproduce=reproduce_command("replay", "probe.beatlog", "--system", "robot:system"),
    )
    return dataclasses.replace(passed, **changes)  # type: ignore[arg-type]


def test_the_reproduce_command_is_the_beatlog_command_line_with_its_arguments() -> None:
    command = reproduce_command("replay", Path("logs/probe.beatlog"), "--system", "robot:system")

    assert command == "beatlog replay logs/probe.beatlog --system robot:system"


@pytest.mark.parametrize(
    "awkward",
    ["my specs/avoid pole.dtc.toml", "it's.beatlog", "$HOME/*.beatlog", "a;rm -rf b", ""],
)
def test_the_reproduce_command_quotes_what_a_shell_would_split_or_expand(awkward: str) -> None:
    command = reproduce_command("test", awkward)

    assert shlex.split(command) == ["beatlog", "test", awkward]
    assert command != f"beatlog test {awkward}"


def test_a_state_change_reads_as_behavior_before_and_after() -> None:
    assert str(StateChange("near", "far", "near")) == "near: 'far' -> 'near'"
    assert str(StateChange("dice", 1, None)) == "dice: 1 -> None"


def test_a_drawn_number_reads_as_behavior_request_and_value() -> None:
    assert str(RandomDraw("dice", "randint", 4, "randint(1, 6)")) == "dice: randint(1, 6) = 4"
    assert str(RandomDraw("wander", "uniform", 0.25)) == "wander: uniform = 0.25"
    assert str(RandomDraw("wander", "uniform", None, "uniform(2, 5)")) == "wander: uniform(2, 5)"
    long = RandomDraw("noise", "normal_array", [[0.5] * 40] * 3, "normal_array(0.0, 1.0, [3, 40])")
    assert str(long).startswith("noise: normal_array(0.0, 1.0, [3, 40]) = [[0.5, 0.5, ")
    assert len(str(long)) < 120


def test_every_divergence_kind_is_its_words_in_a_report() -> None:
    assert [str(kind) for kind in DivergenceKind] == [
        "state changes",
        "outputs",
        "extra random draw",
        "missing random draw",
        "random mismatch",
        "set-up draws",
        "exception",
        "perception",
        "log ended",
        "invariant",
    ]
    assert all(DivergenceKind(kind.value) is kind for kind in DivergenceKind)


def test_a_divergence_tells_its_robot_time_in_seconds() -> None:
    divergence = Divergence(DivergenceKind.OUTPUTS, 41, 1_245_000_000, "speed differs")

    assert divergence.time_s == 1.245
    assert (divergence.expected, divergence.actual, divergence.context) == ((), (), ())
    assert divergence.expected_outputs == divergence.actual_outputs == {}
    assert divergence.traceback is None


def test_a_divergence_tells_its_outputs_as_name_and_value_expected_then_actual() -> None:
    divergence = Divergence(
        DivergenceKind.OUTPUTS,
        41,
        1_245_000_000,
        "speed differs",
        expected_outputs={"speed": 0.5, "mode": "cruise"},
        actual_outputs={"speed": 0.25},
    )

    assert divergence.output_sides == (["speed = 0.5", "mode = 'cruise'"], ["speed = 0.25"])


def test_divergences_do_not_share_their_default_tables() -> None:
    first = Divergence(DivergenceKind.OUTPUTS, 1, 30, "a")
    second = Divergence(DivergenceKind.OUTPUTS, 2, 60, "b")

    first.expected_outputs["speed"] = 0.5

    assert second.expected_outputs == {}


def test_a_divergence_is_a_value_that_cannot_be_changed() -> None:
    divergence = Divergence(
        DivergenceKind.STATE_CHANGES,
        7,
        210_000_000,
        "near changed state differently",
        behavior="near",
        expected=(StateChange("near", "far", "near"),),
        context=(ContextRow(7, 210_000_000, (StateChange("near", "far", "near"),), ()),),
    )

    with pytest.raises(dataclasses.FrozenInstanceError):
        divergence.cycle = 8  # type: ignore[misc]
    assert divergence == dataclasses.replace(divergence)


def test_a_result_tells_robot_time_in_seconds_and_speed_over_real_time() -> None:
    passed = result()

    assert passed.robot_time_s == 9.0
    assert passed.speedup == 18.0


def test_a_result_replayed_in_no_measurable_time_is_infinitely_fast() -> None:
    assert result(wall_time_s=0.0).speedup == float("inf")
