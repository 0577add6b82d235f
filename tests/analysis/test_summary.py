"""Summaries of session logs: the figures ``beatlog show`` prints."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

import msgspec
import pytest

from beatlog.analysis.summary import summarize
from beatlog.log.format import SessionEnd
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.log.writer import SessionLogWriter
from tests.conftest import PERIOD_NS, Probe, RecordFn, distances
from tests.crafting import session_header
from tests.factories import with_damaged_index


def changes_and_draws_in(log: Path) -> tuple[Counter[str], Counter[str]]:
    """Count state changes per behavior name and draws per kind, cycle by cycle."""
    changes, draws = Counter[str](), Counter[str]()
    with SessionLogReader(log) as reader:
        names = reader.header.behaviors
        for cycle in reader.cycles():
            for index, _before, _after in msgspec.msgpack.decode(cycle.state_changes):
                changes[names[index]] += 1
            for _actor, kind, *_ in msgspec.msgpack.decode(cycle.random_numbers):
                draws[kind] += 1
    return changes, draws


def test_a_probe_log_is_summarized_in_figures(record_probe: RecordFn) -> None:
    log = record_probe(300)
    intervals_ms = [(PERIOD_NS + (t % 3) * 1000) / 1e6 for t in range(300)]
    changes, draws = changes_and_draws_in(log)

    summary = summarize(log)

    assert summary.path == log
    assert summary.status == LogStatus(complete=True, cycles=300)
    assert summary.end is not None
    assert summary.end.cycles == 300
    assert summary.cycles == 300
    assert summary.robot_time_ns == sum(PERIOD_NS + (t % 3) * 1000 for t in range(300))
    assert summary.heartbeat_mean_ms == pytest.approx(sum(intervals_ms) / 300)
    assert summary.heartbeat_max_ms == pytest.approx(30.002)
    assert summary.heartbeat_p99_ms == pytest.approx(30.002)
    assert summary.late_beats == 0
    assert list(summary.transitions) == ["arbiter", "near", "dice"]
    assert summary.transitions == {name: changes[name] for name in summary.transitions}
    assert summary.random_draws == dict(draws)


def test_the_figures_match_what_the_probe_was_fed(record_probe: RecordFn) -> None:
    """Near flips each time the distance crosses 0.5; dice rolls one die every 5 cycles."""
    near = [d < 0.5 for d in distances(300)]
    crossings = sum(
        1 for before, after in zip([False, *near], near, strict=False) if before != after
    )

    summary = summarize(record_probe(300))

    assert summary.transitions["near"] == crossings == 6
    assert summary.random_draws == {"randint": len(range(0, 300, 5))}


def write_heartbeats(path: Path, intervals_ns: list[int], *, close: bool = True) -> Path:
    writer = SessionLogWriter(path, session_header(behaviors=["near", "dice"]))
    changes: list[Any] = [(1, "even", "odd"), (0, "far", "near")]
    draws: list[Any] = [(1, "gauss", 0.3), (1, "randint", 4), (-1, "gauss", -1.2)]
    for t, interval in enumerate(intervals_ns):
        writer.append(interval, Probe(), changes if t == 1 else [], draws if t == 2 else [], {})
    if close:
        writer.close(SessionEnd(cycles=len(intervals_ns), robot_time_ns=sum(intervals_ns)))
    else:
        writer.close()
    return path


def test_late_beats_and_the_slowest_beat_are_counted(tmp_path: Path) -> None:
    late = [PERIOD_NS * 2, PERIOD_NS * 3 // 2 + 1]
    on_time = [PERIOD_NS] * 20 + [PERIOD_NS * 3 // 2]
    log = write_heartbeats(tmp_path / "late.beatlog", on_time + late)

    summary = summarize(log)

    assert summary.late_beats == len(late)
    assert summary.heartbeat_max_ms == pytest.approx(60.0)
    assert summary.robot_time_ns == sum(on_time + late)
    assert summary.transitions == {"near": 1, "dice": 1}
    assert summary.random_draws == {"gauss": 2, "randint": 1}


def test_a_log_cut_off_is_summarized_up_to_its_last_cycle(tmp_path: Path) -> None:
    log = write_heartbeats(tmp_path / "cut.beatlog", [PERIOD_NS] * 5, close=False)

    summary = summarize(log)

    assert summary.cycles == 5
    assert summary.end is None
    assert summary.status.describe() == "truncated at cycle 5: the log has no end record"


def test_a_log_whose_index_is_damaged_is_summarized_as_intact_data(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(300)
    damaged = with_damaged_index(log, tmp_path / "index.beatlog")

    summary = summarize(damaged)

    assert summary.status.describe() == (
        "index damaged, data intact: the summary does not match its CRC in the footer"
    )
    assert (summary.cycles, summary.transitions) == (300, summarize(log).transitions)


def test_a_log_without_cycles_has_zero_figures(tmp_path: Path) -> None:
    log = write_heartbeats(tmp_path / "empty.beatlog", [])

    summary = summarize(log)

    assert summary.status == LogStatus(complete=True, cycles=0)
    assert summary.cycles == summary.robot_time_ns == summary.late_beats == 0
    assert summary.heartbeat_mean_ms == summary.heartbeat_max_ms == 0.0
    assert summary.transitions == {"near": 0, "dice": 0}
    assert summary.random_draws == {}
