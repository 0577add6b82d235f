"""The big-baseline bench: the baseline it writes is what the retuned follower's replay
expects, every line of it."""

from __future__ import annotations

from pathlib import Path

from beatlog.baseline.file import read_baseline
from beatlog.replay.judge import replay
from bench_baseline_memory import FIELDS, record, wide_system_retuned, write_big_baseline


def test_the_retuned_follower_passes_against_the_baseline_written(tmp_path: Path) -> None:
    log, path = tmp_path / "big.beatlog", tmp_path / "big.dtc.expected"
    record(log, 120)
    write_big_baseline(path, log, 120)

    baseline = read_baseline(path)
    result = replay(log, wide_system_retuned(), baseline=baseline.stream)

    assert (result.ok, result.cycles) == (True, 120)
    assert len(baseline.whole.outputs) == 120 * FIELDS
