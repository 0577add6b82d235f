"""Rename proposals: only a consistent, one-to-one renaming across the trace is proposed."""

from __future__ import annotations

from beatlog.replay.renames import propose_renames
from beatlog.replay.verdict import StateChange as C


def test_a_consistent_substitution_is_proposed_with_the_winner_states() -> None:
    cycles = [
        ([C("arbiter", "idle", "near"), C("near", "far", "near")],
         [C("arbiter", "idle", "close"), C("close", "far", "near")]),
        ([C("arbiter", "near", "idle")], [C("arbiter", "close", "idle")]),
    ]  # fmt: skip
    assert propose_renames(cycles) == {"near": "close"}


def test_identical_traces_propose_nothing() -> None:
    same = [C("a", 1, 2)]
    assert propose_renames([(same, same)]) == {}


def test_an_inconsistent_substitution_is_not_a_rename() -> None:
    cycles = [([C("a", 0, 1)], [C("b", 0, 1)]), ([C("a", 1, 0)], [C("c", 1, 0)])]
    assert propose_renames(cycles) == {}


def test_two_names_becoming_one_is_not_a_rename() -> None:
    cycles = [([C("a", 0, 1)], [C("c", 0, 1)]), ([C("b", 1, 0)], [C("c", 1, 0)])]
    assert propose_renames(cycles) == {}


def test_a_changed_state_is_not_a_rename() -> None:
    assert propose_renames([([C("a", 0, 1)], [C("b", 0, 2)])]) == {}
    assert propose_renames([([C("a", "x", "y")], [C("b", "x", "z")])]) == {}
    assert propose_renames([([C("a", True, False)], [C("b", 1, 0)])]) == {}


def test_a_missing_change_is_not_a_rename() -> None:
    assert propose_renames([([C("a", 0, 1)], [])]) == {}
