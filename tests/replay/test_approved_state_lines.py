"""The approved robot states' lines checked as a baseline is read, a part at a time: a
run's blocks may come in the parts after its own, and what does not hold together is
found wherever the parts are cut; a robot state's digest counts every bit of the state
as a log encodes it, by XXH64."""

from __future__ import annotations

from beatlog.replay.approved_state_lines import (
    ApprovedRun,
    DigestBlock,
    DigestCoverage,
    state_digest,
)
from tests.factories import encoded

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


def test_a_digest_counts_every_bit_of_the_state_as_a_log_encodes_it() -> None:
    assert state_digest(encoded({"a": 1, "b": 0.5})) == state_digest(encoded({"a": 1, "b": 0.5}))
    assert state_digest(encoded({"a": 0.0})) != state_digest(encoded({"a": -0.0}))
    assert state_digest(encoded({"a": 1})) != state_digest(encoded({"a": 1.0}))
    assert len(state_digest(b"")) == 8


def test_a_digest_is_xxh64_as_its_specification_gives_it() -> None:
    # the empty input's XXH64 (seed 0), from the xxHash specification's test vectors
    assert state_digest(b"") == bytes.fromhex("ef46db3751d8e999")
