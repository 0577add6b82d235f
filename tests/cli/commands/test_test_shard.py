"""``beatlog test --shard I/N``: N CI jobs run every DTC exactly once, about the same
number of recorded cycles each."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from tests.commands import Beatlog, assert_error, closing_counts
from tests.conftest import RecordFn
from tests.specs import write_spec
from tests.text import suite_names, table_row

pytestmark = pytest.mark.usefixtures("wide_plain_console")

CYCLES = {"avoid-pole": 120, "back-off": 30, "corner": 60, "dock": 90, "escape": 20}


@pytest.fixture
def specs(tmp_path: Path, record_probe: RecordFn) -> Path:
    for name, cycles in CYCLES.items():
        write_spec(tmp_path / "specs", name, record_probe(cycles, name=f"{name}.beatlog"))
    return tmp_path / "specs"


def junit_cases(report: Path) -> list[str]:
    return [case.get("name", "") for case in ET.parse(report).getroot().iter("testcase")]


def test_a_matrix_of_shards_runs_every_dtc_once(
    beatlog: Beatlog, specs: Path, tmp_path: Path
) -> None:
    ran: list[list[str]] = []
    for index in (1, 2, 3):
        report = tmp_path / f"shard-{index}.xml"
        run = beatlog("test", specs, "--shard", f"{index}/3", "--junit-xml", report)
        assert run.code == 0, run.err
        ran.append(junit_cases(report))

    assert sorted(name for names in ran for name in names) == sorted(CYCLES)
    # Longest first: 120 to shard 1, 90 to 2, 60 and 30 to 3; then shards 2 and 3 tie
    # at 90 cycles, so 20 goes to the first of them.
    assert ran == [["avoid-pole"], ["dock", "escape"], ["back-off", "corner"]]


def test_a_shard_with_nothing_to_run_passes(beatlog: Beatlog, specs: Path) -> None:
    run = beatlog("test", specs, "--shard", "6/6")

    assert run.code == 0
    assert closing_counts(run.out) == "0 passed, 0 failed"


def test_shards_are_taken_of_the_dtcs_selected(beatlog: Beatlog, specs: Path) -> None:
    run = beatlog("test", specs, "-k", "o", "--shard", "2/2")  # avoid-pole, back-off, dock

    assert run.code == 0
    assert table_row(run.out, "dock")[:4] == ["dock", "passed", "90", "2.7 s"]
    assert suite_names(run.out) == ["corner", "dock"]


@pytest.mark.parametrize(
    ("shard", "problem"),
    [
        ("0/4", "argument --shard: shard '0/4': I must be from 1 to 4 (see 'beatlog test --help')"),
        ("5/4", "argument --shard: shard '5/4': I must be from 1 to 4 (see 'beatlog test --help')"),
        (
            "x",
            "argument --shard: expected a shard I/N such as 2/4, got 'x' "
            "(see 'beatlog test --help')",
        ),
    ],
)
def test_a_shard_that_does_not_exist_is_a_usage_error(
    beatlog: Beatlog, specs: Path, shard: str, problem: str
) -> None:
    assert_error(beatlog("test", specs, "--shard", shard), problem)
