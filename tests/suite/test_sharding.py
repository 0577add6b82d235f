"""Shards for a CI matrix: every DTC in exactly one shard, balanced by recorded cycles,
the same split wherever it is computed."""

from __future__ import annotations

import itertools
import random
import tracemalloc
from pathlib import Path

import pytest

from beatlog.errors import OptionError, RemoteLogError
from beatlog.log.index import recorded_cycles
from beatlog.suite.discovery import discover_specs
from beatlog.suite.sharding import Shard, longest_first, shard, split
from beatlog.suite.spec import DtcSpec
from tests.conftest import RecordFn
from tests.served import LogServer
from tests.specs import write_spec

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
