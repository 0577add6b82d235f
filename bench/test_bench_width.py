"""The wide-state bench: its synthetic system records and replays, the bare loop ends
where replay ends, every float field changes every beat, and each behavior reads 3
fields."""

from __future__ import annotations

from pathlib import Path

import msgspec

from bare import final_states, load_bare_inputs, replay_fresh, run_bare
from bench_width import (
    Cell,
    fields_read,
    maker,
    narrow_state,
    parse_grid,
    record,
    states,
    wide_state,
)


def test_the_synthetic_system_replays_and_the_bare_loop_ends_in_the_same_states(
    tmp_path: Path,
) -> None:
    log = tmp_path / "wide.beatlog"
    figures = record(log, 8, 40, 400)
    result, replayed = replay_fresh(log, maker(8, 40))
    assert result.ok
    assert result.checked.state_changes > 0
    assert result.checked.draws > 0
    assert figures["state_changes_per_cycle"] > 0
    bare = run_bare(load_bare_inputs(log, wide_state(40)), maker(8, 40))
    assert final_states(bare) == final_states(replayed) != final_states(maker(8, 40)())


def test_every_float_changes_every_beat_and_the_kinds_are_mixed() -> None:
    first, second = (msgspec.structs.astuple(state) for state in states(20, 2))
    kinds = [type(value) for value in first]
    assert (kinds.count(float), kinds.count(int), kinds.count(bool)) == (16, 2, 2)
    assert kinds == [type(value) for value in second]
    assert all(a != b for a, b in zip(first, second, strict=True) if type(a) is float)


def test_behaviors_read_3_fields_each_and_the_narrow_state_holds_those_alone() -> None:
    read = fields_read(10, 1000)
    assert len(read) == 30
    assert list(narrow_state(10, 1000).__struct_fields__) == read


def test_the_grid_is_every_cell_or_the_cells_named() -> None:
    assert parse_grid("10x10,100x1000") == [Cell(10, 10), Cell(100, 1000)]
    assert len(parse_grid("all")) == 9
