"""Which DTCs a suite session runs: those found, selected by ``-k``, the tags and the
shard, named apart where they share a name; and the break points a selection takes."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import pytest

from beatlog.errors import OptionError
from beatlog.suite.options import SuiteOptions
from beatlog.suite.selection import check_break_at, fleet_of, select_suite
from beatlog.suite.sharding import Shard
from beatlog.suite.spec import DtcSpec, find_rootdir, load_spec
from tests.conftest import RecordFn
from tests.specs import PROBE, write_spec


@pytest.fixture
def specs(tmp_path: Path, record_probe: RecordFn) -> Path:
    """A folder of three DTCs of one 300-cycle log, two named ``approach``."""
    log = record_probe(300)
    folder = tmp_path / "specs"
    write_spec(folder, "approach", log, tags=["smoke"])
    write_spec(folder / "night", "approach", log)
    write_spec(folder, "retreat", log)
    return folder


def names(specs: Sequence[DtcSpec]) -> list[str]:
    return [spec.label for spec in specs]


def test_every_dtc_found_is_selected_without_an_expression(specs: Path) -> None:
    selection = select_suite(SuiteOptions(paths=(specs,)))

    assert names(selection.specs) == [
        "approach.dtc.toml::approach",
        "night/approach.dtc.toml::approach",
        "retreat",
    ]
    assert len(selection.found) == 3
    assert selection.rootdir == find_rootdir([specs])


def test_k_the_tags_and_the_shard_narrow_the_selection(specs: Path) -> None:
    by_k = select_suite(SuiteOptions(paths=(specs,), pattern="retreat"))
    by_tag = select_suite(SuiteOptions(paths=(specs,), tags=("smoke",)))
    sharded = select_suite(SuiteOptions(paths=(specs,), shard=Shard(1, 3)))

    assert names(by_k.specs) == ["retreat"]
    assert names(by_tag.specs) == ["approach"]
    assert len(sharded.specs) == 1
    assert len(by_k.found) == len(by_tag.found) == len(sharded.found) == 3


def test_a_selection_of_nothing_is_an_option_error(specs: Path, tmp_path: Path) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()

    with pytest.raises(OptionError) as unmatched:
        select_suite(SuiteOptions(paths=(specs,), pattern="nothing"))
    with pytest.raises(OptionError) as unfound:
        select_suite(SuiteOptions(paths=(empty,)))

    assert str(unmatched.value) == f"none of the 3 DTC specs in {specs} match -k/--tag"
    assert str(unfound.value) == f"no DTC specs to run in {empty} (looked for *.dtc.toml)"


def test_a_fleet_run_selects_its_logs_without_a_rootdir(record_probe: RecordFn) -> None:
    log = record_probe(30)
    options = SuiteOptions(logs=str(log), system=PROBE)

    selection = select_suite(options, fleet_of(options))

    assert [spec.log for spec in selection.specs] == [log]
    assert selection.rootdir is None


def test_specs_are_no_fleet() -> None:
    assert fleet_of(SuiteOptions()) is None


def test_a_break_stops_in_one_dtc(specs: Path) -> None:
    two = select_suite(SuiteOptions(paths=(specs,), pattern="approach")).specs

    with pytest.raises(OptionError) as refused:
        check_break_at(12, two, option="--break-at")

    assert str(refused.value) == (
        "--break-at stops in one DTC, and 2 are selected: name its spec or select it with -k"
    )


def test_a_break_past_the_end_of_the_log_is_refused(specs: Path) -> None:
    spec = load_spec(specs / "retreat.dtc.toml")

    check_break_at(299, [spec], option="--beatlog-break-at")
    with pytest.raises(OptionError) as refused:
        check_break_at(300, [spec], option="--beatlog-break-at")

    assert str(refused.value) == (
        f"--beatlog-break-at 300: {spec.log} has only 300 cycles; no break would be reached"
    )


def test_no_break_takes_any_selection(specs: Path) -> None:
    check_break_at(None, select_suite(SuiteOptions(paths=(specs,))).specs, option="--break-at")


def test_variants_asked_of_dtcs_that_declare_none_are_noted(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(50)
    write_spec(tmp_path, "plain", log)

    selection = select_suite(SuiteOptions(paths=(tmp_path,), variants=3))

    assert [spec.name for spec in selection.specs] == ["plain"]
    assert selection.note == (
        "--variants: no DTC selected declares variants "
        "([variants] in its spec, or [tool.beatlog.variants])"
    )


def test_variants_follow_each_dtc_that_declares_them(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(50)
    write_spec(tmp_path, "varied", log, variants={"count": 1})
    write_spec(tmp_path, "zplain", log)

    selection = select_suite(SuiteOptions(paths=(tmp_path,), variants=2))

    assert [spec.name for spec in selection.specs] == [
        "varied",
        "varied[variant-1]",
        "varied[variant-2]",
        "zplain",
    ]
    assert selection.note is None
