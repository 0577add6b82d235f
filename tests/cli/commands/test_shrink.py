"""``beatlog shrink``: a failing DTC shrunk to a window, written as a spec that ``beatlog
test`` fails the same way; a passing one exits 1, bad input is one line and exit 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.commands import Beatlog, assert_error
from tests.conftest import RecordFn, first_cycle_below
from tests.factories import cut_in_half
from tests.specs import PROBE, write_spec
from tests.systems import WORN_OUT

pytestmark = pytest.mark.usefixtures("outside_ci", "wide_plain_console")

WEARY = "tests.systems:weary_system"
WORN_OUT_CYCLE = first_cycle_below(0.5) + 100 * (WORN_OUT - 1)


def test_a_shrunk_spec_fails_the_same_way_under_beatlog_test(
    beatlog: Beatlog, tmp_path: Path, record_probe: RecordFn
) -> None:
    spec = write_spec(tmp_path, "weary", record_probe(600), WEARY)
    shrunk = tmp_path / "weary.shrunk.dtc.toml"

    run = beatlog("shrink", spec)
    original, again = beatlog("test", spec), beatlog("test", shrunk)

    assert (run.code, run.err) == (0, "")
    lines = run.out.splitlines()
    assert lines[0] == (
        f"shrunk exception in near at cycle {WORN_OUT_CYCLE}: "
        f"{WORN_OUT_CYCLE + 1} cycles to the failure -> window "
        f"{WORN_OUT_CYCLE}-{WORN_OUT_CYCLE} (1 judged, {WORN_OUT_CYCLE} replayed before it)"
    )
    assert lines[1:] == [
        lines[1],
        f"wrote {shrunk} (beatlog test {shrunk})",
    ]
    assert lines[1].startswith("replays tried: ")
    assert (original.code, again.code) == (1, 1)
    raised = "near raised RuntimeError: worn out"
    assert raised in original.out
    assert raised in again.out
    assert f"cycle {WORN_OUT_CYCLE}" in again.out


def test_a_failure_that_needs_no_history_is_shrunk_to_a_fresh_start(
    beatlog: Beatlog, tmp_path: Path, record_probe: RecordFn
) -> None:
    spec = write_spec(tmp_path, "fragile", record_probe(300), "tests.systems:fragile_system")
    cycle = first_cycle_below(0.3)

    run = beatlog("shrink", spec)

    assert (run.code, run.err) == (0, "")
    assert run.out.splitlines()[0] == (
        f"shrunk exception in dice at cycle {cycle}: {cycle + 1} cycles to the failure "
        f"-> window {cycle}-{cycle} (1 judged, fresh start)"
    )
    assert "fresh_start = true" in (tmp_path / "fragile.shrunk.dtc.toml").read_text("utf-8")


def test_a_spec_that_passes_is_one_line_and_exit_1(
    beatlog: Beatlog, tmp_path: Path, record_probe: RecordFn
) -> None:
    spec = write_spec(tmp_path, "calm", record_probe(60), PROBE)

    run = beatlog("shrink", spec)

    assert (run.code, run.out, run.err) == (1, f"{spec}: nothing to shrink: it passes\n", "")


@pytest.mark.parametrize(
    ("window", "problem"),
    [
        ({"start_cycle": 20, "end_cycle": 10}, "key 'start_cycle': 20 is after end_cycle 10"),
        (
            {"end_cycle": 60},
            "end_cycle 60 is past the log's last cycle (59)",
        ),
    ],
)
def test_a_window_out_of_range_is_one_line_and_exit_2(
    beatlog: Beatlog,
    tmp_path: Path,
    record_probe: RecordFn,
    window: dict[str, int],
    problem: str,
) -> None:
    spec = write_spec(tmp_path, "off", record_probe(60), WEARY, **window)

    run = beatlog("shrink", spec)

    assert_error(run, f"{spec}: " + problem.format(spec=spec))


def test_a_missing_spec_is_one_line_and_exit_2(beatlog: Beatlog, tmp_path: Path) -> None:
    run = beatlog("shrink", tmp_path / "gone.dtc.toml")

    assert_error(run, f"{tmp_path / 'gone.dtc.toml'}: no such file")


def test_a_dtc_failing_only_because_its_log_was_cut_off_is_one_line_and_exit_2(
    beatlog: Beatlog, tmp_path: Path, record_chunked: RecordFn
) -> None:
    spec = write_spec(tmp_path, "cut", cut_in_half(record_chunked(300)), PROBE)

    run = beatlog("shrink", spec)

    assert_error(run, f"{spec}: fails only because its log was cut off: no window repeats that")
