"""The layouts bench: one session recorded both ways, each replayed against the bare
loop, with a line per layout."""

from __future__ import annotations

import re
from pathlib import Path

from bench_layouts import compare


def test_both_layouts_of_a_width_are_recorded_replayed_and_reported(tmp_path: Path) -> None:
    lines = compare(tmp_path, 4, 20, 60, 1)
    pattern = [
        r"B=4, F=20: bare [\d.]+ µs/cycle",
        r"  records: [\d.]+ bytes/cycle, replay [\d.]+ µs/cycle, replay / bare [\d.]+",
        r"  by field: [\d.]+ bytes/cycle, replay [\d.]+ µs/cycle, replay / bare [\d.]+",
        r"  by field / records, median of the rounds: [\d.]+",
    ]
    assert [bool(re.fullmatch(p, line)) for p, line in zip(pattern, lines, strict=True)] == [
        True
    ] * 4
    assert sorted(path.name for path in tmp_path.iterdir()) == [
        "by-field-20.beatlog",
        "records-20.beatlog",
    ]
