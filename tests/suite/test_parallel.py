"""The suite runner: one verdict per spec, in spec order, here or in worker processes."""

from __future__ import annotations

import dataclasses
import itertools
import os
import random
import tracemalloc
from collections.abc import Iterable
from pathlib import Path

import pytest

from beatlog.errors import OptionError, RemoteLogError
from beatlog.log.index import recorded_cycles
from beatlog.suite.discovery import discover_specs
from beatlog.suite.parallel import Shard, longest_first, run_suite, shard, split
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.spec import DtcSpec
from beatlog.suite.variants import with_variants
from tests.conftest import MEETING, RecordFn
from tests.served import LogServer
from tests.specs import CHANGED, FIRST_CHANGED_CYCLE, write_spec, written_dtc


@pytest.fixture
def log(record_probe: RecordFn) -> Path:
    return record_probe(300)


def verdicts(outcomes: Iterable[SpecOutcome]) -> list[tuple[str, Verdict]]:
    return [(outcome.spec.name, outcome.verdict) for outcome in outcomes]


@pytest.fixture
def mixed_suite(tmp_path: Path, log: Path) -> list[DtcSpec]:
    """Five specs in path order: two pass, two fail, one cannot run."""
    specs = tmp_path / "specs"
    return [
        written_dtc(specs, "a-pass", log),
        written_dtc(specs, "b-fail", log, CHANGED),
        written_dtc(specs, "c-error", tmp_path / "lost.beatlog"),
        written_dtc(specs, "d-pass", log),
        written_dtc(specs, "e-fail", log, CHANGED),
    ]


EXPECTED = [
    ("a-pass", Verdict.PASSED),
    ("b-fail", Verdict.FAILED),
    ("c-error", Verdict.ERROR),
    ("d-pass", Verdict.PASSED),
    ("e-fail", Verdict.FAILED),
]


def test_a_suite_gives_one_outcome_per_spec_in_spec_order(mixed_suite: list[DtcSpec]) -> None:
    seen: list[SpecOutcome] = []

    outcomes = run_suite(mixed_suite, on_outcome=seen.append)

    assert verdicts(outcomes) == EXPECTED
    assert seen == outcomes


def test_worker_processes_give_the_same_verdicts_in_spec_order(
    mixed_suite: list[DtcSpec],
) -> None:
    seen: list[SpecOutcome] = []

    sequential = run_suite(mixed_suite, jobs=1)
    parallel = run_suite(mixed_suite, jobs=2, on_outcome=seen.append)

    assert verdicts(parallel) == verdicts(sequential) == EXPECTED
    assert [o.spec for o in parallel] == mixed_suite
    assert sorted(verdicts(seen)) == EXPECTED  # once per spec, in the order they finished
    failed = parallel[1].result
    assert failed is not None
    assert failed.divergence is not None
    assert failed.divergence.cycle == FIRST_CHANGED_CYCLE
    assert parallel[2].error == sequential[2].error


def test_an_empty_suite_runs_nothing() -> None:
    assert run_suite([], jobs=4) == []


def test_fail_fast_stops_after_the_first_failure(mixed_suite: list[DtcSpec]) -> None:
    seen: list[SpecOutcome] = []

    outcomes = run_suite(mixed_suite, fail_fast=True, on_outcome=seen.append)

    assert verdicts(outcomes) == [("a-pass", Verdict.PASSED), ("b-fail", Verdict.FAILED)]
    assert seen == outcomes


def test_fail_fast_also_stops_at_an_error(mixed_suite: list[DtcSpec]) -> None:
    without_failures = [spec for spec in mixed_suite if "fail" not in spec.name]

    outcomes = run_suite(without_failures, fail_fast=True)

    assert verdicts(outcomes) == [("a-pass", Verdict.PASSED), ("c-error", Verdict.ERROR)]


def test_fail_fast_in_workers_gives_every_outcome_that_came_back_in_spec_order(
    mixed_suite: list[DtcSpec],
) -> None:
    seen: list[SpecOutcome] = []

    outcomes = run_suite(mixed_suite, jobs=2, fail_fast=True, on_outcome=seen.append)

    assert sorted(verdicts(seen)) == sorted(verdicts(outcomes))
    finished = {o.spec.path for o in seen}
    assert [o.spec for o in outcomes] == [s for s in mixed_suite if s.path in finished]
    assert any(o.verdict is not Verdict.PASSED for o in outcomes)


def test_with_two_jobs_specs_run_here_and_in_a_worker_at_once(
    tmp_path: Path, log: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two specs that finish only when they run at the same time, in two processes."""
    meeting = tmp_path / "meeting"
    meeting.mkdir()
    monkeypatch.setenv(MEETING, str(meeting))
    suite = [
        written_dtc(tmp_path, name, log, "tests.conftest:meeting_system") for name in ("a", "b")
    ]

    outcomes = run_suite(suite, jobs=2)

    assert verdicts(outcomes) == [("a", Verdict.PASSED), ("b", Verdict.PASSED)]
    pids = {int(sign.name) for sign in meeting.iterdir()}
    assert len(pids) == 2
    assert os.getpid() in pids


def test_variants_spread_over_worker_processes_each_with_its_own_outcome(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(100, start_time_ns=1_700_000_000_000_000_000)  # its variants keyed
    spec = written_dtc(
        tmp_path, "dock", log, "tests.systems:fussy_system", variants={"noise": {"distance": 0.05}}
    )
    suite = with_variants([spec], 4)

    sequential = run_suite(suite, jobs=1)
    parallel = run_suite(suite, jobs=2)

    assert [o.spec.id for o in parallel] == [spec.id for spec in suite]
    assert [(o.verdict, o.result) for o in parallel] == [
        (o.verdict, dataclasses.replace(o.result, wall_time_s=p.result.wall_time_s))
        for o, p in zip(sequential, parallel, strict=True)
        if o.result is not None and p.result is not None
    ]
    assert Verdict.FAILED in {o.verdict for o in parallel}


# shards for a CI matrix


CYCLES = {
    "avoid-pole": 300,
    "back-off": 40,
    "corner": 120,
    "dock": 40,
    "escape": 10,
    "follow-wall": 200,
    "gap": 80,
    "hallway": 80,
    "idle": 5,
    "junction": 60,
    "kerb": 150,
    "loop": 20,
}


def test_a_dtc_that_crashes_its_worker_process_is_an_error_and_the_others_run_on(
    tmp_path: Path, log: Path, meeting: Path
) -> None:
    suite = [written_dtc(tmp_path, name, log, "tests.conftest:crashing_system") for name in "abcd"]

    outcomes = run_suite(suite, jobs=2)

    assert (meeting / "crashed").exists()
    crashed = [outcome for outcome in outcomes if outcome.verdict is Verdict.ERROR]
    assert [outcome.error for outcome in crashed] == [
        "the worker process ended (exit 3) while replaying it (a crash, or the process killed)"
    ]
    assert [outcome.verdict for outcome in outcomes].count(Verdict.PASSED) == 3


@pytest.fixture
def suite(tmp_path: Path, record_probe: RecordFn) -> list[DtcSpec]:
    """Twelve DTCs whose recordings last from 5 to 300 cycles."""
    for name, cycles in CYCLES.items():
        write_spec(tmp_path / "specs", name, record_probe(cycles, name=f"{name}.beatlog"))
    return discover_specs([tmp_path / "specs"])


def names(specs: list[DtcSpec]) -> list[str]:
    return [spec.name for spec in specs]


def load(specs: list[DtcSpec]) -> int:
    return sum(recorded_cycles(spec.log) or 0 for spec in specs)


@pytest.mark.parametrize("count", [1, 2, 3, 4, 5, 12, 15])
def test_every_dtc_lands_in_exactly_one_shard(suite: list[DtcSpec], count: int) -> None:
    shards = [shard(suite, index, count) for index in range(1, count + 1)]

    assert sorted(itertools.chain.from_iterable(names(s) for s in shards)) == names(suite)
    for first, second in itertools.combinations(shards, 2):
        assert not set(names(first)) & set(names(second))


@pytest.mark.parametrize("count", [2, 3, 4, 5])
def test_shards_differ_by_at_most_the_longest_recording(suite: list[DtcSpec], count: int) -> None:
    loads = [load(chosen) for chosen in split(suite, count)]

    assert sum(loads) == sum(CYCLES.values())
    assert max(loads) - min(loads) <= max(CYCLES.values())


def test_the_longest_recordings_go_first_to_the_least_loaded_shard(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    for name, cycles in {"a": 100, "b": 300, "c": 200, "d": 100}.items():
        write_spec(tmp_path, name, record_probe(cycles, name=f"{name}.beatlog"))
    specs = discover_specs([tmp_path])

    # b (300) to shard 1, c (200) to shard 2, a (100) to shard 2; then a tie at 300
    # cycles each, so d (100) goes to the first shard.
    assert [names(chosen) for chosen in split(specs, 2)] == [["b", "d"], ["a", "c"]]


def test_the_split_is_the_same_whatever_order_the_specs_come_in(suite: list[DtcSpec]) -> None:
    shuffled = list(suite)
    random.Random(12).shuffle(shuffled)

    assert split(shuffled, 4) == split(suite, 4)
    assert split(list(reversed(suite)), 4) == split(suite, 4)


def test_each_shard_keeps_the_suite_order(suite: list[DtcSpec]) -> None:
    for chosen in split(suite, 3):
        assert [spec.path for spec in chosen] == sorted(spec.path for spec in chosen)


def test_a_log_that_cannot_be_read_counts_no_cycles_and_still_lands_in_one_shard(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    write_spec(tmp_path, "long", record_probe(300, name="long.beatlog"))
    write_spec(tmp_path, "short", record_probe(20, name="short.beatlog"))
    write_spec(tmp_path, "gone", tmp_path / "gone.beatlog")
    cut = tmp_path / "cut.beatlog"
    cut.write_bytes((tmp_path / "long.beatlog").read_bytes()[:-100])
    write_spec(tmp_path, "cut", cut)
    specs = discover_specs([tmp_path])

    shards = split(specs, 2)

    # long (300) to shard 1, short (20) to shard 2, then cut and gone (0 each) to shard 2.
    assert [names(chosen) for chosen in shards] == [["long"], ["cut", "gone", "short"]]


def test_workers_take_the_longest_recordings_first_ties_in_suite_order(
    suite: list[DtcSpec],
) -> None:
    ordered = longest_first(suite)

    assert sorted(names(ordered)) == sorted(CYCLES)
    assert [recorded_cycles(spec.log) for spec in ordered] == sorted(CYCLES.values(), reverse=True)
    assert names(ordered)[4:8] == ["gap", "hallway", "junction", "back-off"]


def url_suite(served: LogServer, tmp_path: Path, record_probe: RecordFn) -> list[DtcSpec]:
    """Three specs by path: a log behind a URL (200 cycles), another (300), and the
    longest here (600)."""
    specs = tmp_path / "specs"
    write_spec(specs, "a-yard", f"{served.url}/yard.beatlog")
    write_spec(specs, "b-dock", f"{served.url}/dock.beatlog")
    write_spec(specs, "c-here", record_probe(600, name="here.beatlog"))
    return discover_specs([specs])


def test_with_logs_behind_urls_every_log_weighs_its_size_and_none_is_downloaded(
    served: LogServer, tmp_path: Path, record_probe: RecordFn
) -> None:
    specs = url_suite(served, tmp_path, record_probe)

    assert [spec.name for spec in longest_first(specs)] == ["c-here", "b-dock", "a-yard"]
    assert split(specs, 2) == [[specs[2]], [specs[0], specs[1]]]
    assert served.sent == {}


def test_a_log_behind_a_url_that_cannot_be_sized_fails_a_split_not_an_ordering(
    served: LogServer, tmp_path: Path, record_probe: RecordFn
) -> None:
    specs = url_suite(served, tmp_path, record_probe)
    (served.folder / "yard.beatlog").unlink()

    assert [spec.name for spec in longest_first(specs)] == ["c-here", "b-dock", "a-yard"]
    with pytest.raises(RemoteLogError, match=r"/yard\.beatlog: no such log$"):
        split(specs, 2)


def test_more_shards_than_dtcs_leaves_the_last_ones_empty(suite: list[DtcSpec]) -> None:
    shards = split(suite[:2], 4)

    assert [len(chosen) for chosen in shards] == [1, 1, 0, 0]


def test_a_shard_of_far_more_than_the_dtcs_is_the_same_and_costs_no_more_memory(
    suite: list[DtcSpec],
) -> None:
    count = 10**6  # --shard I/1000000: planned for one shard per DTC at most
    tracemalloc.start()
    try:
        last = shard(suite, count, count)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()

    assert last == []
    assert peak < 4 << 20
    one_each = split(suite, len(suite))
    assert [shard(suite, index, count) for index in range(1, len(suite) + 2)] == [
        *one_each,
        [],
    ]


@pytest.mark.parametrize(("text", "expected"), [("1/1", Shard(1, 1)), (" 2 / 4 ", Shard(2, 4))])
def test_a_shard_is_written_i_of_n(text: str, expected: Shard) -> None:
    assert Shard.parse(text) == expected
    assert str(Shard.parse(text)) == text.replace(" ", "")


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("0/4", "shard '0/4': I must be from 1 to 4"),
        ("5/4", "shard '5/4': I must be from 1 to 4"),
        ("1/0", "shard '1/0': N must be at least 1"),
        ("x", "expected a shard I/N such as 2/4, got 'x'"),
        ("2", "expected a shard I/N such as 2/4, got '2'"),
        ("-1/4", "expected a shard I/N such as 2/4, got '-1/4'"),
    ],
)
def test_a_shard_that_does_not_exist_is_refused(text: str, problem: str) -> None:
    with pytest.raises(OptionError) as raised:
        Shard.parse(text)

    assert str(raised.value) == problem


def test_a_shard_index_out_of_range_is_a_programming_error(suite: list[DtcSpec]) -> None:
    with pytest.raises(ValueError, match="from 1 to 4"):
        shard(suite, 0, 4)
    with pytest.raises(ValueError, match="at least 1 shard"):
        split(suite, 0)
