"""Timelines: every behavior's states over a session, recorded and replayed, for charts."""

from __future__ import annotations

import itertools
import pickle
from collections.abc import Sequence
from math import nan
from pathlib import Path

import pytest

from beatlog import replay
from beatlog.analysis.details import replay_details
from beatlog.analysis.timeline import (
    CLOSE_UP_NS,
    Interval,
    Mark,
    Timeline,
    TimelineCollector,
    build_timeline,
)
from beatlog.errors import CorruptLogError, FieldError, NotABeatlogError
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import BehaviorState, PriorityArbiter
from beatlog.replay.core import Replayer
from beatlog.replay.verdict import DivergenceKind
from tests.conftest import (
    PERIOD_NS,
    Near,
    Probe,
    RecordFn,
    distances,
    first_cycle_below,
    probe_system,
)
from tests.factories import rewrite_cycle
from tests.systems import Fragile, record_moody


def cycle_times(cycles: int) -> list[int]:
    """The robot time at the end of each cycle of a probe recording."""
    times, now = [], 0
    for t in range(cycles):
        now += PERIOD_NS + (t % 3) * 1000
        times.append(now)
    return times


def states(intervals: Sequence[Interval]) -> list[BehaviorState]:
    return [interval.state for interval in intervals]


def assert_tiles(intervals: Sequence[Interval], start_ns: int, end_ns: int) -> None:
    """The intervals cover [start, end] without gaps or overlaps."""
    assert intervals[0].start_ns == start_ns
    assert intervals[-1].end_ns == end_ns
    for before, after in itertools.pairwise(intervals):
        assert before.end_ns == after.start_ns
        assert before.start_ns < before.end_ns


def lane(timeline: Timeline, behavior: str) -> tuple[tuple[Interval, ...], tuple[Interval, ...]]:
    found = {lane.behavior: lane for lane in timeline.lanes}[behavior]
    return found.expected, found.actual


def test_a_passing_replay_gives_the_same_lanes_recorded_and_replayed(
    record_probe: RecordFn,
) -> None:
    timeline = build_timeline(record_probe(300), probe_system())

    times = cycle_times(300)
    assert (timeline.cycles, timeline.start_ns, timeline.end_ns) == (300, 0, times[-1])
    assert (timeline.replayed, timeline.replayed_until_ns, timeline.divergence) == (
        True,
        times[-1],
        None,
    )
    assert [lane.behavior for lane in timeline.lanes] == ["arbiter", "near", "dice"]
    for found in timeline.lanes:
        assert found.expected == found.actual
        assert_tiles(found.expected, 0, times[-1])
    near, _ = lane(timeline, "near")
    below = [d < 0.5 for d in distances(300)]
    flips = [t for t in range(1, 300) if below[t] != below[t - 1]]
    assert [interval.start_ns for interval in near[1:]] == [times[t] for t in flips]
    assert states(near) == ["far", "near"] * (len(near) // 2) + ["far"] * (len(near) % 2)


def test_a_changed_behavior_is_marked_where_replay_first_differs_and_followed_to_the_end(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    divergence = replay(log, probe_system(threshold=0.6)).divergence
    assert divergence is not None

    timeline = build_timeline(log, probe_system(threshold=0.6), divergence=divergence)

    assert timeline.divergence == Mark(
        divergence.cycle, divergence.time_ns, DivergenceKind.STATE_CHANGES
    )
    expected, actual = lane(timeline, "near")
    assert expected != actual
    assert actual[1].start_ns == divergence.time_ns
    assert expected[1].start_ns > divergence.time_ns
    assert timeline.replayed_until_ns == timeline.end_ns
    assert_tiles(actual, 0, timeline.end_ns)


def test_without_a_system_only_the_recording_is_read(record_probe: RecordFn) -> None:
    log = record_probe(300)

    recorded = build_timeline(log)
    replayed = build_timeline(log, "tests.conftest:probe_system")

    assert (recorded.replayed, recorded.divergence) == (False, None)
    assert all(found.actual == () for found in recorded.lanes)
    assert [found.expected for found in recorded.lanes] == [
        found.expected for found in replayed.lanes
    ]
    assert recorded.signals == replayed.signals


def test_a_behavior_that_never_changed_shows_its_recorded_state_without_a_system(
    record_probe: RecordFn,
) -> None:
    log = record_probe(50, states=[Probe(distance=2.0)] * 50)

    recorded, _ = lane(build_timeline(log), "near")

    assert states(recorded) == ["far"]
    assert_tiles(recorded, 0, build_timeline(log).end_ns)


def test_an_exception_ends_the_replayed_lanes_but_not_the_recorded_ones(
    record_probe: RecordFn,
) -> None:
    cycle = first_cycle_below(0.3)
    log = record_probe(300)
    divergence = replay(log, PriorityArbiter([Near(), Fragile()], robot_state=Probe)).divergence

    timeline = build_timeline(
        log, PriorityArbiter([Near(), Fragile()], robot_state=Probe), divergence=divergence
    )

    times = cycle_times(300)
    assert timeline.divergence == Mark(cycle, times[cycle], DivergenceKind.EXCEPTION)
    assert timeline.replayed_until_ns == times[cycle - 1]
    for found in timeline.lanes:
        assert found.expected[-1].end_ns == times[-1]
        assert found.actual[-1].end_ns == times[cycle - 1]


@pytest.mark.parametrize(
    ("options", "kind", "cycle", "replayed_to_the_end"),
    [
        ({"draws": 2}, DivergenceKind.RANDOM_OVERDRAWN, 0, False),
        ({"every": 10}, DivergenceKind.RANDOM_UNDERDRAWN, 5, True),
    ],
    ids=["overdrawn", "underdrawn"],
)
def test_random_numbers_that_do_not_match_are_marked(
    record_probe: RecordFn,
    options: dict[str, int],
    kind: DivergenceKind,
    cycle: int,
    replayed_to_the_end: bool,
) -> None:
    log = record_probe(50)
    divergence = replay(log, probe_system(**options)).divergence

    timeline = build_timeline(log, probe_system(**options), divergence=divergence)

    assert timeline.divergence == Mark(cycle, cycle_times(50)[cycle], kind)
    # Drawing too many stops replay at once; drawing too few leaves it able to go on.
    assert (timeline.replayed_until_ns == timeline.end_ns) is replayed_to_the_end


def test_departures_replace_the_recording_only_in_the_cycles_they_hold(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    whole = build_timeline(log)
    first = lane(whole, "near")[0][1].start_ns
    cycle = cycle_times(300).index(first)

    quiet = build_timeline(log, expected={cycle: []})  # that change is gone, none instead

    near, _ = lane(quiet, "near")
    recorded, _ = lane(whole, "near")
    # The first change left is near -> far: the lane is near until then.
    assert near == (Interval(0, recorded[2].start_ns, "near"), *recorded[2:])


def test_numeric_robot_state_fields_are_sampled_every_cycle(record_probe: RecordFn) -> None:
    log = record_probe(300)
    timeline = build_timeline(log)

    assert [signal.field for signal in timeline.signals] == ["distance", "reading"]
    distance = timeline.signals[0]
    assert distance.time_ns == tuple(cycle_times(300))
    assert distance.value == tuple(distances(300))
    assert build_timeline(log, fields=["reading"]).signals[0].field == "reading"


@pytest.fixture
def moody_log(tmp_path: Path) -> Path:
    return record_moody(tmp_path / "moody.beatlog")


def test_flags_are_drawn_as_zero_and_one_and_text_fields_are_left_out(moody_log: Path) -> None:
    timeline = build_timeline(moody_log)

    assert [signal.field for signal in timeline.signals] == ["level", "bumped"]
    assert timeline.signals[1].value == (0.0, 1.0) * 5
    assert [signal.flag for signal in timeline.signals] == [False, True]


@pytest.mark.parametrize(
    ("field", "problem"),
    [
        ("speed", "the robot state has no field 'speed' (numeric fields: level, bumped)"),
        ("mood", "robot-state field 'mood' is a str, not a number (numeric fields: level, bumped)"),
    ],
)
def test_a_field_that_cannot_be_drawn_is_bad_input_naming_the_log(
    moody_log: Path, field: str, problem: str
) -> None:
    with pytest.raises(FieldError) as raised:
        build_timeline(moody_log, fields=["level", field])

    assert str(raised.value) == f"{moody_log}: {problem}"


def test_a_missing_log_is_bad_input(tmp_path: Path) -> None:
    with pytest.raises(NotABeatlogError, match="no such file"):
        build_timeline(tmp_path / "lost.beatlog")


def test_a_damaged_robot_state_is_bad_input_naming_its_cycle(
    record_probe: RecordFn, tmp_path: Path
) -> None:
    log = rewrite_cycle(  # cycle 7's robot state an array
        record_probe(60), tmp_path / "damaged.beatlog", 7, lambda p: [p[0], [1, 2], *p[2:]]
    )

    with pytest.raises(CorruptLogError, match=r"damaged robot state in cycle 7: "):
        build_timeline(log)


def test_a_value_that_is_not_a_number_is_no_point_of_its_signal(
    record_probe: RecordFn, tmp_path: Path
) -> None:
    log = rewrite_cycle(  # cycle 7's distance NaN
        record_probe(60),
        tmp_path / "nan.beatlog",
        7,
        lambda p: [p[0], p[1] | {"distance": nan}, *p[2:]],
    )

    for buckets in (60, 4):  # a bucket a cycle, and buckets merged as the session grew
        distance = build_timeline(log, max_points=buckets).signals[0]
        assert cycle_times(60)[7] not in distance.time_ns
        assert all(value == value for value in distance.value)  # NaN is not itself
    assert build_timeline(log).signals[0].value == tuple(
        value for cycle, value in enumerate(distances(60)) if cycle != 7
    )


def test_a_long_session_is_downsampled_to_a_few_points_per_pixel(record_probe: RecordFn) -> None:
    log = record_probe(300)
    full = build_timeline(log, probe_system())

    small = build_timeline(log, probe_system(), max_points=20)

    dice, _ = lane(small, "dice")
    full_dice, _ = lane(full, "dice")
    assert len(dice) < len(full_dice) / 2
    assert any(interval.flicker for interval in dice)
    assert sum(interval.flicker + 1 for interval in dice) == len(full_dice)
    assert_tiles(dice, 0, full.end_ns)
    distance = small.signals[0]
    assert len(distance.value) <= 40
    assert min(distance.value) == min(distances(300))
    assert max(distance.value) == max(distances(300))
    assert list(distance.time_ns) == sorted(distance.time_ns)


def test_a_window_keeps_only_that_stretch_of_robot_time(record_probe: RecordFn) -> None:
    log = record_probe(300)
    divergence = replay(log, probe_system(threshold=0.6)).divergence
    assert divergence is not None

    close_up, whole = replay_details(
        log, probe_system(threshold=0.6), divergence, timelines=True
    ).timelines

    assert whole.start_ns == 0
    assert close_up.start_ns == max(divergence.time_ns - CLOSE_UP_NS, 0)
    assert close_up.end_ns == divergence.time_ns + CLOSE_UP_NS
    assert close_up.cycles < whole.cycles
    assert close_up.divergence == whole.divergence
    for found in close_up.lanes:
        assert_tiles(found.expected, close_up.start_ns, close_up.end_ns)
        assert_tiles(found.actual, close_up.start_ns, close_up.end_ns)
    assert close_up.signals[0].time_ns[-1] <= close_up.end_ns
    late = build_timeline(log, window_ns=(6_000_000_000, 7_000_000_000))
    assert late.signals[0].time_ns[0] >= 6_000_000_000
    assert_tiles(late.lanes[0].expected, 6_000_000_000, 7_000_000_000)


def test_a_report_marks_the_verdicts_divergence_even_one_the_timeline_cannot_see(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    log.write_bytes(log.read_bytes()[:-200])  # cut off: replay fails as ending early
    divergence = replay(log, probe_system()).divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.LOG_ENDED
    assert build_timeline(log, probe_system()).divergence is None

    close_up, whole = replay_details(log, probe_system(), divergence, timelines=True).timelines

    mark = Mark(divergence.cycle, divergence.time_ns, DivergenceKind.LOG_ENDED)
    assert close_up.divergence == whole.divergence == mark


def test_a_passing_dtc_gets_just_the_whole_session(record_probe: RecordFn) -> None:
    (whole,) = replay_details(record_probe(50), probe_system(), None, timelines=True).timelines

    assert whole.divergence is None
    assert whole.cycles == 50


def test_a_timeline_survives_the_trip_from_a_worker_process(record_probe: RecordFn) -> None:
    timeline = build_timeline(record_probe(300), probe_system(threshold=0.6))

    assert pickle.loads(pickle.dumps(timeline)) == timeline


def collect(log: Path, cycles: int, buckets: int) -> TimelineCollector:
    """A collector fed the first ``cycles`` cycles of ``log``, replayed on the probe system."""
    system = probe_system(threshold=0.45)  # near flips often against the recording
    with SessionLogReader(log) as reader:
        replayer = Replayer(system, reader.header, reader.path)
        collector = TimelineCollector(reader, system, buckets=buckets)
        for record in itertools.islice(reader.cycles(), cycles):
            replayer.advance(record)
            collector.add(record, replayer.outcome())
    return collector


def test_what_a_collector_holds_is_bounded_by_its_buckets_not_the_cycles(
    record_probe: RecordFn,
) -> None:
    log = record_probe(4000)
    buckets = 16
    signals, lanes = 2, 3 * 2  # distance and reading; three behaviors, recorded and replayed
    bound = signals * buckets + lanes * (2 * buckets + 1)

    held = [collect(log, cycles, buckets).held for cycles in (100, 1000, 4000)]

    assert all(0 < count <= bound for count in held), held
    whole = collect(log, 4000, buckets).timeline(None)
    assert all(len(signal.time_ns) <= 2 * buckets for signal in whole.signals)
    assert whole.signals[0].time_ns[-1] <= whole.end_ns
    assert min(whole.signals[0].value) == min(distances(4000))
    assert max(whole.signals[0].value) == max(distances(4000))
    for found in whole.lanes:
        assert len(found.expected) <= 2 * buckets + 1
        assert_tiles(found.expected, 0, whole.end_ns)
        assert_tiles(found.actual, 0, whole.end_ns)


def test_a_collector_keeps_every_state_change_it_folds(record_probe: RecordFn) -> None:
    log = record_probe(4000)
    full = collect(log, 4000, 4000).timeline(None)

    folded = collect(log, 4000, 16).timeline(None)

    for fine, coarse in zip(full.lanes, folded.lanes, strict=True):
        assert sum(interval.flicker + 1 for interval in coarse.expected) == len(fine.expected)
        assert coarse.expected[-1].state == fine.expected[-1].state
