"""The approved robot states' lines checked as a baseline is read, a part at a time: a
run's blocks may come in the parts after its own, and what does not hold together is
found wherever the parts are cut."""

from __future__ import annotations

import pytest

from beatlog.baseline.digests import DigestCoverage
from beatlog.replay.approved_state_lines import ApprovedRun, DigestBlock

RUN = ApprovedRun(10, 0, 140, 131, ("speed",), {"speed": 1.0})
BLOCKS = [
    DigestBlock(10, 0, "AA" * 64, bytes(8)),
    DigestBlock(74, 0, "AA" * 64, bytes(8)),
    DigestBlock(138, 0, "AA" * 3, bytes(8)),
]


def _problem(*parts: tuple[list[ApprovedRun], list[DigestBlock]]) -> str | None:
    coverage = DigestCoverage()
    for runs, blocks in parts:
        problem = coverage.add(runs, blocks)
        if problem is not None:
            return problem
    return coverage.end()


def test_a_runs_blocks_may_come_in_later_parts() -> None:
    assert _problem(([RUN], BLOCKS)) is None
    assert _problem(([RUN], BLOCKS[:1]), ([], BLOCKS[1:2]), ([], BLOCKS[2:])) is None


def test_a_run_short_of_blocks_is_found_at_the_end_whatever_the_parts() -> None:
    problem = "the robot-state run from cycle 10 says 131 cycles, its digests pin 67"

    assert _problem(([RUN], [BLOCKS[0], BLOCKS[2]])) == problem
    assert _problem(([RUN], BLOCKS[:1]), ([], BLOCKS[2:])) == problem


def test_a_block_in_no_run_or_out_of_place_is_found_in_its_part() -> None:
    assert _problem(([RUN], BLOCKS), ([], [DigestBlock(200, 0, "AA", bytes(8))])) == (
        "the digests from cycle 200 are in no robot-state run"
    )
    assert _problem(([RUN], BLOCKS[:2]), ([], BLOCKS[1:])) == (
        "the robot-state run from cycle 10 has its digests of cycle 74 out of place"
    )


def _run(cycle: int, last: int, cycles: int) -> ApprovedRun:
    return ApprovedRun(cycle, 0, last, cycles, ("speed",), {"speed": 1.0})


def _block(cycle: int, tags: str) -> DigestBlock:
    return DigestBlock(cycle, 0, tags, bytes(8))


@pytest.mark.parametrize(
    ("runs", "blocks", "problem"),
    [
        ((_run(0, 1, 2),), (), "the robot-state run from cycle 0 has digests that do not end"),
        ((_run(0, 1, 2),), (_block(1, "AA"),), "has its digests of cycle 1 out of place"),
        ((_run(0, 1, 2),), (_block(0, "AAAA"),), None),
        ((_run(0, 1, 3),), (_block(0, "AAAA"),), "says 3 cycles, its digests pin 2"),
        ((_run(0, 2, 2),), (_block(0, "AA..AA"),), None),
        ((_run(0, 1, 2),), (_block(0, "AAAAAA"),), "do not end at its last cycle, 1"),
        ((_run(0, 1, 2),), (_block(0, "AA"), _block(0, "AA")), "digests of cycle 0 out of place"),
        ((_run(0, 0, 1),), (_block(0, "A."),), "has not 1 to 64 tags from cycle 0"),
        ((_run(0, 1, 2),), (_block(0, "A..A"),), "has not 1 to 64 tags from cycle 0"),
        ((_run(0, 0, 1),), (_block(0, "AAA"),), "has not 1 to 64 tags from cycle 0"),
        ((_run(0, 0, 1),), (_block(0, "A-"),), "has not 1 to 64 tags from cycle 0"),
        ((_run(0, 0, 1),), (_block(0, "A\x00"),), "has not 1 to 64 tags from cycle 0"),
        ((_run(0, 0, 1),), (_block(0, "A\u00e9"),), "has not 1 to 64 tags from cycle 0"),
        ((_run(0, 1, 2),), (_block(0, "x.xA"),), "has not 1 to 64 tags from cycle 0"),
        ((_run(0, 0, 1),), (_block(0, ""),), "has not 1 to 64 tags from cycle 0"),
        ((_run(0, 0, 1),), (_block(0, "AA" * 65),), "has not 1 to 64 tags from cycle 0"),
        ((_run(0, 0, 1), _run(0, 0, 1)), (_block(0, "AA"),), "from cycle 0 is out of order"),
        ((_run(0, 0, 1),), (_block(0, "AA"), _block(5, "AA")), "from cycle 5 are in no robot"),
        (
            (ApprovedRun(0, 0, 0, 1, ("speed",), {"heading": 1.0}),),
            (_block(0, "AA"),),
            "names no fields that differ in its first cycle",
        ),
    ],
)
def test_blocks_must_cover_their_runs(
    runs: tuple[ApprovedRun, ...], blocks: tuple[DigestBlock, ...], problem: str | None
) -> None:
    found = _problem((list(runs), list(blocks)))

    if problem is None:
        assert found is None
    else:
        assert found is not None
        assert problem in found
