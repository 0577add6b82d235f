"""The allowances a spec may grant: renames, ignored behaviors and fields, tolerances."""

from __future__ import annotations

import math

import pytest

from beatlog.replay.compare import Comparison
from beatlog.replay.verdict import StateChange

CHANGES = [StateChange("arbiter", "idle", "avoid"), StateChange("avoid", "off", "turning")]


def test_exact_comparison_compares_states_by_type() -> None:
    exact = Comparison()
    assert exact.changes_agree(CHANGES, list(CHANGES))
    assert not exact.changes_agree(CHANGES, CHANGES[:1])
    assert not exact.changes_agree([StateChange("flag", False, True)], [StateChange("flag", 0, 1)])


def test_a_renamed_behavior_agrees_under_its_new_name_and_as_a_winner() -> None:
    comparison = Comparison(renames={"avoid": "dodge"})
    expected = [comparison.renamed(change) for change in CHANGES]
    assert expected[1].behavior == "dodge"
    actual = [StateChange("arbiter", "idle", "dodge"), StateChange("dodge", "off", "turning")]
    assert comparison.changes_agree(expected, actual)
    assert not Comparison().changes_agree(CHANGES, actual)


def test_ignored_behaviors_are_left_out_on_both_sides() -> None:
    comparison = Comparison(ignore_behaviors=frozenset({"avoid"}))
    assert comparison.changes_agree(CHANGES, CHANGES[:1])
    assert not comparison.changes_agree(CHANGES, [StateChange("arbiter", "idle", "wander")])


def test_a_cycles_state_changes_agree_in_any_order_of_behaviors() -> None:
    exact = Comparison()
    assert exact.changes_agree(CHANGES, CHANGES[::-1])
    assert exact.only_order_differs(CHANGES, CHANGES[::-1])
    assert not exact.only_order_differs(CHANGES, CHANGES)


def test_each_behaviors_own_changes_keep_their_order() -> None:
    twice = [StateChange("avoid", "off", "turning"), StateChange("avoid", "turning", "backing")]
    exact = Comparison()
    assert not exact.changes_agree(twice, twice[::-1])
    assert not exact.only_order_differs(twice, twice[::-1])
    assert exact.first_differing_behavior(twice, twice[::-1]) == "avoid"


def test_the_first_differing_behavior_is_named_expected_ones_first() -> None:
    exact = Comparison()
    changed = [StateChange("avoid", "off", "backing"), StateChange("arbiter", "idle", "wander")]
    assert exact.first_differing_behavior(CHANGES, changed) == "arbiter"
    assert exact.first_differing_behavior(CHANGES[1:], changed) == "avoid"
    assert exact.first_differing_behavior([], CHANGES) == "arbiter"
    assert exact.first_differing_behavior(CHANGES, CHANGES[::-1]) is None


def test_outputs_compare_bit_for_bit_by_default() -> None:
    exact = Comparison()
    assert exact.outputs_agree({"v": 0.5, "w": 1.0}, {"w": 1.0, "v": 0.5})
    assert exact.outputs_agree({"v": math.nan}, {"v": math.nan})
    assert not exact.outputs_agree({"v": 0.0}, {"v": -0.0})
    assert not exact.outputs_agree({"v": 0.5}, {"v": 0.5 + 1e-12})
    assert not exact.outputs_agree({"v": 0.5}, {"v": 0.5, "w": 1.0})


@pytest.mark.parametrize(
    ("expected", "actual", "agree"),
    [
        (0.5, 0.5 + 1e-7, True),
        (0.5, 0.5 + 1e-5, False),
        ([0.1, 0.2], [0.1 + 1e-7, 0.2 - 1e-7], True),
        ([0.1, 0.2], [0.1], False),
        (math.inf, math.inf, True),
        (math.inf, -math.inf, False),
        (math.nan, 0.0, False),
        ("fast", "fast", True),
        (True, 1, False),
    ],
)
def test_a_field_tolerance_accepts_small_differences(
    expected: object, actual: object, *, agree: bool
) -> None:
    comparison = Comparison(tolerance={"v": 1e-6})
    assert comparison.outputs_agree({"v": expected}, {"v": actual}) is agree


def test_ignored_fields_match_by_name_or_glob() -> None:
    comparison = Comparison(ignore_fields=("debug_*", "stamp"))
    assert comparison.outputs_agree(
        {"v": 1.0, "debug_cost": 3, "stamp": 1}, {"v": 1.0, "debug_cost": 4, "debug_x": 0}
    )
    assert not comparison.outputs_agree({"v": 1.0}, {"v": 2.0, "stamp": 1})
