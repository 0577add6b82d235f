"""``beatlog show``: a log's header, figures and behaviors, and what state it is in."""

from __future__ import annotations

import itertools
import re
import sys
from pathlib import Path

import pytest

from beatlog.analysis.summary import summarize
from tests.commands import Beatlog
from tests.conftest import RecordFn
from tests.factories import cut_in_half, with_damaged_index
from tests.systems import record_driver, record_scatter
from tests.text import whole_lines

pytestmark = pytest.mark.usefixtures("wide_plain_console")


def about_rows(out: str) -> dict[str, str]:
    """The name-value lines ``show`` prints above its behaviors table."""
    about = itertools.takewhile(lambda line: line.strip() != "behaviors", out.splitlines())
    pairs = (line.strip().partition("  ") for line in about)
    return {name: value.strip() for name, _, value in pairs}


def table_rows(out: str) -> list[list[str]]:
    """The cells of each row of the behaviors table."""
    rows = [line for line in out.splitlines() if line.startswith("│")]
    return [[cell.strip() for cell in row.split("│")[1:-1]] for row in rows]


def test_show_describes_a_log(beatlog: Beatlog, record_probe: RecordFn) -> None:
    log = record_probe(300, robot_id="probe-1")
    summary = summarize(log)

    run = beatlog("show", log)

    assert run.code == 0
    about = about_rows(run.out)
    assert about["log"] == str(log)
    assert about["status"] == "complete"
    assert about["robot"] == "probe-1"
    assert about["cycles"] == "300"
    assert "random numbers  60 (randint 60)" in whole_lines(run.out)
    assert table_rows(run.out) == [
        [str(index), name, str(count)]
        for index, (name, count) in enumerate(summary.transitions.items())
    ]
    assert [row[1] for row in table_rows(run.out)] == ["arbiter", "near", "dice"]


def test_show_counts_the_draws_made_at_set_up(beatlog: Beatlog, tmp_path: Path) -> None:
    log = record_driver(tmp_path / "driver.beatlog")

    run = beatlog("show", log)

    assert run.code == 0
    assert about_rows(run.out)["set-up draws"] == "2 (uniform 1, normal_array 1)"
    assert "set-up draws" not in beatlog("show", record_scatter(tmp_path / "s.beatlog")).out


def test_show_says_a_cut_off_log_is_truncated(beatlog: Beatlog, record_chunked: RecordFn) -> None:
    log = cut_in_half(record_chunked(300))

    run = beatlog("show", log)

    assert run.code == 0
    status = re.compile(r"status +truncated at cycle \d+: the last record is cut off at byte \d+")
    assert len([line for line in whole_lines(run.out) if status.fullmatch(line)]) == 1
    assert "overruns        unknown (no end record); 0 beats later than 1.5 periods" in whole_lines(
        run.out
    )


def test_show_says_a_log_whose_index_is_damaged_holds_its_data_intact(
    tmp_path: Path, beatlog: Beatlog, record_probe: RecordFn
) -> None:
    log = with_damaged_index(record_probe(300), tmp_path / "index.beatlog")

    run = beatlog("show", log)

    assert run.code == 0
    assert about_rows(run.out)["status"] == (
        "index damaged, data intact: the summary does not match its CRC in the footer"
    )
    assert about_rows(run.out)["cycles"] == "300"


def test_show_describes_a_log_of_array_draws_without_numpy(
    beatlog: Beatlog, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_scatter(tmp_path / "arrays.beatlog", cycles=30)
    monkeypatch.setitem(sys.modules, "numpy", None)

    run = beatlog("show", log)

    assert run.code == 0
    assert about_rows(run.out)["random numbers"] == "6 (uniform_array 6)"
