"""Approved robot states, pinned by digest: any bit of any field counts, in the cycle
where it differs, and they stay a few characters a cycle."""

from __future__ import annotations

import itertools
import math
from typing import Any

from beatlog.replay.approved_state_lines import CYCLES_PER_BLOCK, GAP_TAG, ApprovedRun, DigestBlock
from beatlog.replay.approved_states import (
    MAX_GAP,
    ApprovedStateChecker,
    ApprovedStates,
    rebuilt_otherwise,
)
from tests.factories import encoded, rebuilt_states, speed_state


def _judged(approved: ApprovedStates, states: dict[int, dict[str, Any]]) -> dict[int, str]:
    """Each pinned cycle judged in order: the cycles found to differ, and how."""
    checker = ApprovedStateChecker(approved)
    found = {
        cycle: checker.mismatch(cycle, encoded(states[cycle])) for cycle in sorted(checker.tags)
    }
    return {cycle: how for cycle, how in found.items() if how is not None}


def test_approved_states_judge_by_their_digest() -> None:
    states = {cycle: speed_state(cycle) for cycle in range(100)}
    approved = ApprovedStates.from_rebuilt(rebuilt_states(states))
    changed = {**states, 40: {**states[40], "bumped": True}}

    assert (_judged(approved, states), _judged(approved, changed)) == ({}, {40: "by its digest"})


def test_only_the_fields_that_differ_bit_for_bit_are_rebuilt_otherwise() -> None:
    recorded = {"speed": 0.0, "heading": 1.5, "gone": 1}
    rebuilt = {"speed": -0.0, "heading": 1.5, "new": 2}
    assert rebuilt_otherwise(recorded, rebuilt) == {"speed": -0.0, "new": 2}


def test_the_states_approved_states_were_made_from_agree() -> None:
    states = {cycle: speed_state(cycle) for cycle in range(200)}
    approved = ApprovedStates.from_rebuilt(rebuilt_states(states))
    assert _judged(approved, states) == {}


def test_a_one_ulp_change_of_one_field_in_one_cycle_fails_in_that_cycle() -> None:
    states = {cycle: speed_state(cycle) for cycle in range(200)}
    approved = ApprovedStates.from_rebuilt(rebuilt_states(states))
    changed = dict(states)
    changed[117] = {**states[117], "heading": math.nextafter(states[117]["heading"], 9.0)}

    assert _judged(approved, changed) == {117: "by its digest"}


def test_a_change_whose_tag_matches_fails_at_the_end_of_its_block() -> None:
    states = {cycle: speed_state(cycle) for cycle in range(100)}
    approved = ApprovedStates.from_rebuilt(rebuilt_states(states))
    block = approved.blocks[0]
    heading = states[5]["heading"]
    # one in 4,096 changes keeps the cycle's 12-bit tag: find one
    for _ in itertools.count():
        heading = math.nextafter(heading, 9.0)
        twin = {**states[5], "heading": heading}
        (same_tag,) = ApprovedStates.from_rebuilt(rebuilt_states({5: twin})).blocks
        if same_tag.tags == block.tags[10:12]:  # cycle 5's tag
            break

    found = _judged(approved, {**states, 5: twin})

    assert found == {CYCLES_PER_BLOCK - 1: f"by the digest of cycles 0–{CYCLES_PER_BLOCK - 1}"}


def test_consecutive_cycles_make_one_run_of_blocks() -> None:
    states = {cycle: speed_state(cycle) for cycle in range(10, 150)}

    approved = ApprovedStates.from_rebuilt(rebuilt_states(states))

    assert approved.runs == (ApprovedRun(10, 10_000_000, 149, 140, ("speed",), {"speed": 0.01}),)
    assert [(block.cycle, block.cycles) for block in approved.blocks] == [
        (10, 64),
        (74, 64),
        (138, 12),
    ]
    assert all(len(block.tags) == 2 * block.cycles for block in approved.blocks)
    assert approved.cycles == 140


def test_short_gaps_stay_in_the_run_and_are_judged_against_the_recording() -> None:
    cycles = [0, 1, 2 + MAX_GAP, 3 + MAX_GAP, 4 + 3 * MAX_GAP]
    states = {cycle: speed_state(cycle) for cycle in cycles}

    approved = ApprovedStates.from_rebuilt(rebuilt_states(states))

    assert [(run.cycle, run.last, run.cycles) for run in approved.runs] == [
        (0, 3 + MAX_GAP, 4),
        (4 + 3 * MAX_GAP, 4 + 3 * MAX_GAP, 1),
    ]
    first = approved.blocks[0]
    assert first.tags[4 : 4 + 2 * MAX_GAP] == GAP_TAG * MAX_GAP
    tags = [first.tags[at : at + 2] for at in range(0, len(first.tags), 2)]
    assert [at for at, tag in enumerate(tags) if tag != GAP_TAG] == [0, 1, 2 + MAX_GAP, 3 + MAX_GAP]
    assert ApprovedStateChecker(approved).tags.keys() == set(cycles)
    assert _judged(approved, states) == {}


def test_a_block_starts_at_a_pinned_cycle_and_ends_at_one() -> None:
    cycles = [*range(CYCLES_PER_BLOCK - 3), CYCLES_PER_BLOCK + 6, CYCLES_PER_BLOCK + 8]
    states = {cycle: speed_state(cycle) for cycle in cycles}

    approved = ApprovedStates.from_rebuilt(rebuilt_states(states))

    assert len(approved.runs) == 1
    assert [(block.cycle, block.cycles) for block in approved.blocks] == [
        (0, CYCLES_PER_BLOCK - 3),
        (CYCLES_PER_BLOCK + 6, 3),
    ]


def test_a_pinned_cycle_left_unjudged_leaves_its_block_digest_unchecked() -> None:
    states = {cycle: speed_state(cycle) for cycle in range(64)}
    checker = ApprovedStateChecker(ApprovedStates.from_rebuilt(rebuilt_states(states)))

    found = [checker.mismatch(cycle, encoded(states[cycle])) for cycle in range(64) if cycle != 3]

    assert found == [None] * 63


def test_a_cycle_found_to_differ_is_found_so_when_asked_again() -> None:
    states = {cycle: speed_state(cycle) for cycle in range(3)}
    checker = ApprovedStateChecker(ApprovedStates.from_rebuilt(rebuilt_states(states)))
    wrong = {**states[0], "speed": 9.0}

    assert checker.mismatch(0, encoded(wrong)) == "by its digest"
    assert checker.found(0, encoded(states[0])) == "by its digest"
    assert checker.mismatch(1, encoded(states[1])) is None
    assert checker.found(1, encoded(states[1])) is None


def test_a_block_found_to_differ_is_found_so_when_its_last_cycle_is_asked_again() -> None:
    states = {cycle: speed_state(cycle) for cycle in range(4)}
    approved = ApprovedStates.from_rebuilt(rebuilt_states(states))
    (block,) = approved.blocks
    checker = ApprovedStateChecker(
        ApprovedStates(approved.runs, (block._replace(digest=bytes(8)),))
    )
    found = [checker.mismatch(cycle, encoded(states[cycle])) for cycle in range(4)]

    assert found == [None, None, None, "by the digest of cycles 0–3"]
    assert checker.found(3, encoded(states[3])) == "by the digest of cycles 0–3"


def test_a_block_is_judged_by_its_own_cycles_only() -> None:
    states = {cycle: speed_state(cycle) for cycle in range(2 * CYCLES_PER_BLOCK)}
    checker = ApprovedStateChecker(ApprovedStates.from_rebuilt(rebuilt_states(states)))
    # The first block's last cycle and all but the second's last are never judged:
    # as many digests are left as the second block approved, none of them its own.
    judged = [*range(CYCLES_PER_BLOCK - 1), 2 * CYCLES_PER_BLOCK - 1]
    found = {cycle: checker.mismatch(cycle, encoded(states[cycle])) for cycle in judged}

    assert set(found.values()) == {None}


def test_a_one_cycle_block_opens_and_closes_on_its_own_cycle() -> None:
    state = speed_state(7)
    approved = ApprovedStates.from_rebuilt(rebuilt_states({7: state}))
    (block,) = approved.blocks
    wrong_digest = ApprovedStates(approved.runs, (block._replace(digest=bytes(8)),))

    assert [cycle in ApprovedStateChecker(approved) for cycle in (6, 7, 8)] == [False, True, False]
    assert ApprovedStateChecker(approved).mismatch(7, encoded(state)) is None
    assert (
        ApprovedStateChecker(approved).mismatch(7, encoded({**state, "speed": 9.0}))
        == "by its digest"
    )
    assert (
        ApprovedStateChecker(wrong_digest).mismatch(7, encoded(state))
        == "by the digest of cycles 7–7"
    )


def test_a_checker_reads_each_pinned_cycle_its_tag_gaps_left_out() -> None:
    digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/"
    tags = [*(a + b for a, b in zip(digits, reversed(digits), strict=True)), "/A", "A/", "//"]
    tags[10] = GAP_TAG  # a gap
    blocks = (
        DigestBlock(0, 0, "".join(tags[:64]), bytes(8)),
        DigestBlock(64, 0, "".join(tags[64:]), bytes(8)),
    )
    checker = ApprovedStateChecker(ApprovedStates((_run(0, 63, 63), _run(64, 66, 3)), blocks))

    read = [checker.tags.get(cycle) for cycle in range(len(tags))]
    assert read == [None if tag == GAP_TAG else tag for tag in tags]


def _run(cycle: int, last: int, cycles: int) -> ApprovedRun:
    return ApprovedRun(cycle, 0, last, cycles, ("speed",), {"speed": 1.0})


def _block(cycle: int, tags: str) -> DigestBlock:
    return DigestBlock(cycle, 0, tags, bytes(8))


def test_an_approved_state_at_a_far_cycle_costs_no_more_than_a_near_one() -> None:
    far = 10**12  # a cycle number a baseline may give: bounded by nothing but its digits
    approved = ApprovedStates((_run(far, far + 1, 2),), (_block(far, "AAAB"),))

    checker = ApprovedStateChecker(approved)

    assert checker.tags.keys() == {far, far + 1}
    assert far - 1 not in checker
