"""An approved baseline's draw rules, judged cycle by cycle."""

from __future__ import annotations

from beatlog.replay.draws import DrawLedger, DrawRule, Unapproved, draw_rules
from beatlog.replay.random import DrawDifference

RETUNED = DrawDifference("wander", "uniform(0.8, 1.6)", "uniform(0.7, 1.5)")
NEW = DrawDifference("escape", None, "uniform(4.0, 8.0)")


def test_rules_group_the_differences_with_their_cycles_in_a_stable_order() -> None:
    rules = draw_rules([(40, RETUNED), (12, NEW), (12, RETUNED), (12, NEW)])

    assert rules == (
        DrawRule("escape", None, "uniform(4.0, 8.0)", (12, 12)),
        DrawRule("wander", "uniform(0.8, 1.6)", "uniform(0.7, 1.5)", (12, 40)),
    )
    assert [str(rule) for rule in rules] == [
        "escape: 2 new draws of uniform(4.0, 8.0)",
        "wander: uniform(0.8, 1.6) -> uniform(0.7, 1.5), 2 draws re-mapped",
    ]


def test_the_ledger_accepts_exactly_the_approved_differences_of_a_cycle() -> None:
    ledger = DrawLedger(draw_rules([(12, RETUNED), (12, NEW)]))

    assert ledger.cycles == frozenset({12})
    assert ledger.check(12, [NEW, RETUNED]) is None
    assert ledger.check(13, []) is None


def test_the_ledger_names_a_difference_made_where_none_is_approved() -> None:
    ledger = DrawLedger(draw_rules([(12, RETUNED)]))

    assert ledger.check(13, [RETUNED]) == Unapproved(RETUNED, made=True, approved_elsewhere=True)
    assert ledger.check(12, [RETUNED, NEW]) == Unapproved(NEW, made=True, approved_elsewhere=False)


def test_the_ledger_names_an_approved_difference_not_made() -> None:
    ledger = DrawLedger(draw_rules([(12, RETUNED), (12, RETUNED)]))

    assert ledger.check(12, [RETUNED]) == Unapproved(RETUNED, made=False, approved_elsewhere=True)


def test_the_ledger_approves_a_cycle_exactly_where_it_finds_nothing_to_name() -> None:
    ledger = DrawLedger(draw_rules([(12, RETUNED), (12, RETUNED), (12, NEW)]))
    cycles = [
        (12, [NEW, RETUNED, RETUNED]),
        (12, [RETUNED, NEW]),
        (12, [RETUNED, RETUNED, NEW, NEW]),
        (12, []),
        (13, []),
        (13, [NEW]),
    ]

    approved = [ledger.approves(cycle, made) for cycle, made in cycles]

    assert approved == [True, False, False, False, True, False]
    assert approved == [ledger.check(cycle, made) is None for cycle, made in cycles]


def test_the_ledger_approves_a_single_difference_only_where_it_alone_is_approved() -> None:
    ledger = DrawLedger(draw_rules([(12, NEW), (14, RETUNED), (14, RETUNED), (15, RETUNED)]))
    cycles = [(12, [NEW]), (12, [RETUNED]), (14, [RETUNED]), (15, [RETUNED]), (16, [NEW])]

    approved = [ledger.approves(cycle, made) for cycle, made in cycles]

    assert approved == [True, False, False, True, False]
    assert approved == [ledger.check(cycle, made) is None for cycle, made in cycles]
