"""The first divergence written up: the rename map a divergence proposes where the
behaviors differ from those expected only by a consistent renaming."""

from beatlog import StateChange
from beatlog.replay.divergence import propose_renames


def test_rename_proposal_a_consistent_substitution_is_proposed_with_the_winner_states() -> None:
    cycles = [
        ([StateChange("arbiter", "idle", "near"), StateChange("near", "far", "near")],
         [StateChange("arbiter", "idle", "close"), StateChange("close", "far", "near")]),
        ([StateChange("arbiter", "near", "idle")], [StateChange("arbiter", "close", "idle")]),
    ]  # fmt: skip
    assert propose_renames(cycles) == {"near": "close"}


def test_rename_proposal_identical_traces_propose_nothing() -> None:
    same = [StateChange("a", 1, 2)]
    assert propose_renames([(same, same)]) == {}


def test_rename_proposal_an_inconsistent_substitution_is_not_a_rename() -> None:
    cycles = [
        ([StateChange("a", 0, 1)], [StateChange("b", 0, 1)]),
        ([StateChange("a", 1, 0)], [StateChange("c", 1, 0)]),
    ]
    assert propose_renames(cycles) == {}


def test_rename_proposal_two_names_becoming_one_is_not_a_rename() -> None:
    cycles = [
        ([StateChange("a", 0, 1)], [StateChange("c", 0, 1)]),
        ([StateChange("b", 1, 0)], [StateChange("c", 1, 0)]),
    ]
    assert propose_renames(cycles) == {}


def test_rename_proposal_a_changed_state_is_not_a_rename() -> None:
    assert propose_renames([([StateChange("a", 0, 1)], [StateChange("b", 0, 2)])]) == {}
    assert propose_renames([([StateChange("a", "x", "y")], [StateChange("b", "x", "z")])]) == {}
    assert propose_renames([([StateChange("a", True, False)], [StateChange("b", 1, 0)])]) == {}


def test_rename_proposal_a_missing_change_is_not_a_rename() -> None:
    assert propose_renames([([StateChange("a", 0, 1)], [])]) == {}
