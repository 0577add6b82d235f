"""Whether a failure repeats."""

from __future__ import annotations

import dataclasses

from beatlog.replaying.verdict import Divergence, DivergenceKind
from beatlog.suite.repeats import repeat_note

FIRST = Divergence(kind=DivergenceKind.OUTPUTS, cycle=12, time_ns=360, message="outputs differ")
AUDIT = "beatlog test --audit a.dtc.toml"


def test_a_failure_that_repeats_itself_has_no_note() -> None:
    assert repeat_note(FIRST, dataclasses.replace(FIRST, message="as before"), AUDIT) == ()


def test_a_failure_that_moves_or_passes_the_next_time_points_to_the_audit() -> None:
    moved = dataclasses.replace(FIRST, cycle=14)
    otherwise = dataclasses.replace(FIRST, actual_outputs={"speed": float("nan")})

    notes = [repeat_note(FIRST, again, AUDIT) for again in (None, moved, otherwise)]

    assert [note[0].split(" on unchanged code")[0] for note in notes] == [
        "fails at cycle 12 in one run and passes in the next",
        "fails at a different cycle each run (12, then 14)",
        "fails otherwise each run at cycle 12",
    ]
    assert all(note[0].endswith(f"run `{AUDIT}` to find the call") for note in notes)
