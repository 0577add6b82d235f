"""The live bench: each way runs the dog's own loop, and its figures are the intervals'."""

from __future__ import annotations

from pathlib import Path

import pytest

from bench_live import Beats, figures, recorded, unrecorded


def test_figures_are_percentiles_of_the_intervals_and_the_cpu() -> None:
    intervals = [30_000_000] * 99 + [40_000_000]
    beats = Beats(intervals=intervals, cpu=[100_000] * 100, overruns=1, rounds=[50, 100])

    assert figures(beats) == {
        "cycles": 100,
        "p50_ms": 30.0,
        "p99_ms": pytest.approx(30.1),
        "round_p99_ms": [30.0, pytest.approx(35.1)],
        "max_ms": 40.0,
        "cpu_p50_us": 100.0,
        "cpu_p99_us": 100.0,
        "overruns": 1,
    }


def test_each_way_adds_its_beats_and_leaves_no_log(tmp_path: Path) -> None:
    pooled = {"unrecorded": Beats(), "with samples": Beats()}

    unrecorded(0.3, pooled["unrecorded"])
    recorded(0.3, pooled["with samples"], tmp_path, log_samples=True)

    for beats in pooled.values():  # 10 beats of 30 ms, fewer where a loaded machine overran
        assert 1 <= len(beats.intervals) <= 10
        assert len(beats.cpu) == len(beats.intervals)
        assert beats.rounds == [len(beats.intervals)]
    assert list(tmp_path.iterdir()) == []
