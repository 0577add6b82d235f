"""A baseline's approved draws, judged cycle by cycle."""

from __future__ import annotations

from beatlog.replay.draws import (
    ApprovedDraws,
    DrawApprovals,
    DrawMadeOtherwise,
    UnapprovedDraw,
    approved_draws,
)

RETUNED = DrawMadeOtherwise("wander", "uniform(0.8, 1.6)", "uniform(0.7, 1.5)")
NEW = DrawMadeOtherwise("escape", None, "uniform(4.0, 8.0)")


def test_approved_draws_group_draws_made_otherwise_by_way_in_a_stable_order() -> None:
    approved = approved_draws([(40, RETUNED), (12, NEW), (12, RETUNED), (12, NEW)])

    assert approved == (
        ApprovedDraws("escape", None, "uniform(4.0, 8.0)", (12, 12)),
        ApprovedDraws("wander", "uniform(0.8, 1.6)", "uniform(0.7, 1.5)", (12, 40)),
    )
    assert [str(line) for line in approved] == [
        "escape: 2 new draws of uniform(4.0, 8.0)",
        "wander: uniform(0.8, 1.6) -> uniform(0.7, 1.5), 2 draws re-mapped",
    ]


def test_draw_approvals_accepts_exactly_the_approved_draws_of_a_cycle() -> None:
    approvals = DrawApprovals(approved_draws([(12, RETUNED), (12, NEW)]))

    assert approvals.check(12, [NEW, RETUNED]) is None
    assert approvals.check(13, []) is None


def test_draw_approvals_names_a_draw_made_where_none_is_approved() -> None:
    approvals = DrawApprovals(approved_draws([(12, RETUNED)]))

    assert approvals.check(13, [RETUNED]) == UnapprovedDraw(
        RETUNED, made=True, approved_elsewhere=True
    )
    assert approvals.check(12, [RETUNED, NEW]) == UnapprovedDraw(
        NEW, made=True, approved_elsewhere=False
    )


def test_draw_approvals_names_an_approved_draw_not_made() -> None:
    approvals = DrawApprovals(approved_draws([(12, RETUNED), (12, RETUNED)]))

    assert approvals.check(12, [RETUNED]) == UnapprovedDraw(
        RETUNED, made=False, approved_elsewhere=True
    )


def test_draw_approvals_approves_a_cycle_exactly_where_it_finds_nothing_to_name() -> None:
    approvals = DrawApprovals(approved_draws([(12, RETUNED), (12, RETUNED), (12, NEW)]))
    cycles = [
        (12, [NEW, RETUNED, RETUNED]),
        (12, [RETUNED, NEW]),
        (12, [RETUNED, RETUNED, NEW, NEW]),
        (12, []),
        (13, []),
        (13, [NEW]),
    ]

    approved = [approvals.approves(cycle, made) for cycle, made in cycles]

    assert approved == [True, False, False, False, True, False]
    assert approved == [approvals.check(cycle, made) is None for cycle, made in cycles]


def test_draw_approvals_approves_a_single_draw_only_where_it_alone_is_approved() -> None:
    approvals = DrawApprovals(
        approved_draws([(12, NEW), (14, RETUNED), (14, RETUNED), (15, RETUNED)])
    )
    cycles = [(12, [NEW]), (12, [RETUNED]), (14, [RETUNED]), (15, [RETUNED]), (16, [NEW])]

    approved = [approvals.approves(cycle, made) for cycle, made in cycles]

    assert approved == [True, False, False, True, False]
    assert approved == [approvals.check(cycle, made) is None for cycle, made in cycles]
