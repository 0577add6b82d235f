"""The bare loop that replay is measured against runs the same behaviors on the same
inputs, and ends in the same behavior states as replay, for the rover and the dog."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from bare import (
    final_states,
    load_bare_inputs,
    replay_against_bare,
    replay_fresh,
    run_bare,
    run_checked,
)
from beatlog.model.behavior import System
from beatlog_examples import dog, rover

DOG_LOG = dog.SUITE_DIR / "escape-bump.beatlog"


def rover_log(directory: Path) -> Path:
    path = directory / "rover.beatlog"
    rover.record_lockstep(path, duration_s=120.0, seed=2)  # a seed whose session includes bumps
    return path


EXAMPLES: dict[str, tuple[Callable[[Path], Path], Callable[[], System]]] = {
    "rover": (rover_log, rover.system),
    "dog": (lambda _: DOG_LOG, dog.system),
}


@pytest.mark.parametrize("example", EXAMPLES)
def test_the_bare_loop_ends_in_the_states_replay_ends_in(tmp_path: Path, example: str) -> None:
    log_of, make = EXAMPLES[example]
    log = log_of(tmp_path)
    inputs = load_bare_inputs(log, make().robot_state)
    result, replayed = replay_fresh(log, make)
    assert result.ok
    assert len(inputs.states) == result.cycles
    assert inputs.draws
    bare = run_bare(inputs, make)
    assert final_states(bare) == final_states(replayed)
    assert final_states(bare) != final_states(make())  # the behaviors did something
    assert final_states(run_checked(log, make)) == final_states(replayed)


def test_the_checked_loop_fails_where_replay_diverges() -> None:
    assert not replay_fresh(DOG_LOG, dog.changed_system)[0].ok
    with pytest.raises(AssertionError, match="cycles failed the checked loop"):
        run_checked(DOG_LOG, dog.changed_system)


def test_replay_against_bare_reports_every_round() -> None:
    figures = replay_against_bare(DOG_LOG, dog.system, rounds=2)
    assert figures["replay_ok"]
    assert figures["same_final_states"]
    assert len(figures["replay_cpu_s"]) == len(figures["bare_cpu_s"]) == 2
    assert figures["replay_over_bare"] > 0
    assert figures["checked_over_bare"] > 0
