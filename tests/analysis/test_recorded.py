"""What a log recorded, gathered batch by batch: by a replay that reads it, or alone."""

from __future__ import annotations

from beatlog.analysis.recorded import RecordedChanges, read_changes
from beatlog.log.reader import SessionLogReader
from beatlog.replay.baseline import TracedStateChange
from beatlog.replay.judge import replay
from beatlog.replay.verdict import StateChange
from tests.conftest import RecordFn, probe_system


def test_a_log_read_alone_gives_its_changes_named_with_their_cycles_and_times(
    record_probe: RecordFn,
) -> None:
    recorded = read_changes(record_probe(300))

    assert (recorded.cycles, recorded.system, recorded.reference) == (
        300,
        "tests.conftest:probe_system",
        "tests.conftest:probe_system",
    )
    assert len(recorded.changes) == 45
    assert recorded.changes[:3] == [
        TracedStateChange(0, 30_000_000, StateChange("arbiter", "idle", "dice")),
        TracedStateChange(0, 30_000_000, StateChange("dice", "even", "odd")),
        TracedStateChange(10, 330_010_000, StateChange("dice", "odd", "even")),
    ]


def test_a_replay_that_stops_early_still_reads_the_whole_log_for_its_readers(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    kept: list[RecordedChanges] = []

    def reader(opened: SessionLogReader) -> RecordedChanges:
        kept.append(RecordedChanges(opened))
        return kept[-1]

    result = replay(log, probe_system(threshold=0.6), readers=[reader])

    assert result.divergence is not None
    assert result.cycles < 300
    (recorded,) = kept
    alone = read_changes(log)
    assert (recorded.changes, recorded.cycles) == (alone.changes, alone.cycles)
