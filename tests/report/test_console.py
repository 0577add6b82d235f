"""The console report: a pass in one line, a failure in one screen."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

from beatlog import replay
from beatlog.analysis.summary import summarize
from beatlog.replay.verdict import Checked, DivergenceKind
from beatlog.report.console import (
    MAX_LISTED,
    plain_text,
    render_passed,
    render_replay,
    render_suite,
    render_summary,
)
from beatlog.suite.discovery import distinguished
from beatlog.suite.runner import SpecOutcome, Verdict, run_spec
from beatlog.suite.spec import DtcSpec, load_spec
from tests.conftest import RecordFn, probe_system
from tests.specs import CHANGED, PROBE, write_spec
from tests.systems import never_close
from tests.text import suite_names, table_row, whole_lines


def test_a_pass_is_one_verdict_line(record_probe: RecordFn) -> None:
    log = record_probe(50)

    text = plain_text(render_replay(replay(log, probe_system())), width=400)

    assert re.fullmatch(
        rf"PASS {re.escape(str(log))}  50 cycles, \d+ state changes, \d+ outputs, "
        r"\d+ draws checked; 1\.5 s robot time "
        r"(?:in [\d.]+ s \([\d,.]+× real time\)|in under 1 ms); "
        r"log complete\n",
        text,
    ), text


def test_a_failure_shows_cycle_changes_state_and_an_unwrapped_command(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300, name="a-rather-long-name-for-a-session-log-" * 3 + ".beatlog")
    text = plain_text(render_replay(replay(log, probe_system(threshold=0.6))), width=80)
    assert "first divergence: cycle 21, t = 0.660 s, state changes" in whole_lines(text)
    assert table_row(text, "▶ 21") == ["▶ 21", "0.660", "—", "arbiter: 'dice' -> 'near'"]
    assert "robot state RS_t" in whole_lines(text)
    (command,) = [line for line in text.splitlines() if line.startswith("reproduce: ")]
    assert command.endswith("--system tests.conftest:probe_system")
    assert len(text.splitlines()) < 50


def test_a_pass_line_says_what_the_replay_checked(record_probe: RecordFn) -> None:
    log = record_probe(300)
    result = dataclasses.replace(
        replay(log, probe_system()), checked=Checked(12, 40, 9), wall_time_s=0.0002
    )

    assert plain_text(render_replay(result), width=400) == (
        f"PASS {log}  300 cycles, 12 state changes, 40 outputs, 9 draws checked; "
        "9.0 s robot time in under 1 ms; log complete\n"
    )


def test_a_pass_allowed_to_check_nothing_says_so(record_probe: RecordFn) -> None:
    log = record_probe(300)
    result = dataclasses.replace(replay(log, probe_system()), checked=Checked(), wall_time_s=0.0002)

    assert plain_text(render_replay(result), width=400) == (
        f"PASS {log}  300 cycles checked (allowed empty); 9.0 s robot time in under 1 ms; "
        "log complete\n"
    )


def test_a_passing_dtc_s_line_names_it_and_what_it_checked(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(300)
    outcome = run_spec(load_spec(write_spec(tmp_path, "walk", log)))
    assert outcome.result is not None
    checked = dataclasses.replace(outcome.result, checked=Checked(12, 40, 9, 300))

    text = plain_text(render_passed(dataclasses.replace(outcome, result=checked)))

    assert (
        text
        == "PASS walk: 300 cycles, 12 state changes, 40 outputs, 9 draws, 300 samples checked\n"
    )


def test_one_cycle_is_one_cycle(record_probe: RecordFn) -> None:
    log = record_probe(1)
    result = replay(log, probe_system())
    once = dataclasses.replace(result, checked=Checked(1, 1, 1, 1), wall_time_s=0.0002)

    text = plain_text(render_replay(once), width=400)

    assert text == (
        f"PASS {log}  1 cycle, 1 state change, 1 output, 1 draw, 1 sample checked; "
        "0.0 s robot time in under 1 ms; log complete\n"
    )


def test_a_replay_too_short_to_time_reports_no_speed_up(record_probe: RecordFn) -> None:
    log = record_probe(1)
    result = replay(log, probe_system())
    instant = dataclasses.replace(result, wall_time_s=0.0002)
    timed = dataclasses.replace(result, wall_time_s=0.015)

    verdict = f"PASS {log}  1 cycle, 2 state changes, 2 outputs, 1 draw checked; 0.0 s robot time"
    assert plain_text(render_replay(instant), width=400) == (
        f"{verdict} in under 1 ms; log complete\n"
    )
    assert plain_text(render_replay(timed), width=400) == (
        f"{verdict} in 0.015 s (2× real time); log complete\n"
    )


def test_a_replay_slower_than_real_time_says_how_much_slower(record_probe: RecordFn) -> None:
    log = record_probe(1)
    result = replay(log, probe_system())
    slow = dataclasses.replace(result, wall_time_s=0.1)
    still = dataclasses.replace(result, wall_time_s=0.1, robot_time_ns=0)

    verdict = f"PASS {log}  1 cycle, 2 state changes, 2 outputs, 1 draw checked; 0.0 s robot time"
    assert plain_text(render_replay(slow), width=400) == (
        f"{verdict} in 0.100 s (0.3× real time); log complete\n"
    )
    assert plain_text(render_replay(still), width=400) == f"{verdict} in 0.100 s; log complete\n"


def test_a_truncated_log_suggests_allowing_it_in_full(record_chunked: RecordFn) -> None:
    log = record_chunked(300)
    log.write_bytes(log.read_bytes()[: log.stat().st_size // 2])

    text = plain_text(render_replay(replay(log, probe_system())), width=80)

    panel = " ".join(whole_lines(text)[2:5])
    assert re.fullmatch(
        r"the log ends early \(truncated at cycle \d+: the last record is cut off at byte \d+\); "
        r"if the session ended there \(a crash\), accept what it holds with --allow-truncated "
        r"\(in a spec: allow_truncated = true\)",
        panel,
    ), panel


def test_the_summary_names_every_behavior(record_probe: RecordFn) -> None:
    text = plain_text(render_summary(summarize(record_probe(100))))

    fields = [line.split() for line in text.splitlines()]
    assert ["status", "complete"] in fields
    behaviors = [
        [cell.strip() for cell in line.strip("│").split("│")]
        for line in text.splitlines()
        if line.startswith("│")
    ]
    assert behaviors == [["0", "arbiter", "3"], ["1", "near", "2"], ["2", "dice", "10"]]


def test_the_cycles_around_a_divergence_are_a_table(record_probe: RecordFn) -> None:
    result = replay(record_probe(300), probe_system(threshold=0.6), context_cycles=40)
    text = plain_text(render_replay(result))
    assert "state changes around it" in whole_lines(text)
    assert table_row(text, "▶ 21") == ["▶ 21", "0.660", "—", "arbiter: 'dice' -> 'near'"]


def test_a_failure_shows_only_the_robot_state_fields_read(record_probe: RecordFn) -> None:
    result = replay(record_probe(300), CHANGED)
    text = plain_text(render_replay(result), width=120)
    assert "robot state RS_t, fields read in this cycle" in whole_lines(text)
    assert table_row(text, "distance") == ["distance", "0.58"]
    assert "reading" not in text
    assert "1 more field not read" in whole_lines(text)


def test_a_rename_proposal_gives_the_line_for_the_spec(record_probe: RecordFn) -> None:
    result = replay(record_probe(300), "tests.conftest:probe_system_renamed")
    text = plain_text(render_replay(result), width=200)
    assert "The whole trace differs only by renamed behaviors: near → close" in whole_lines(text)
    assert 'If intended, add to the spec: renames = { "near" = "close" }' in whole_lines(text)


def outcomes(passed: int, failed: int = 0, errors: int = 0) -> list[SpecOutcome]:
    """Outcomes of a suite, passes first; enough to draw its summary table."""
    verdicts = [Verdict.PASSED] * passed + [Verdict.FAILED] * failed + [Verdict.ERROR] * errors
    return [
        SpecOutcome(
            DtcSpec(Path(f"dtc-{n:03}.dtc.toml"), f"dtc-{n:03}", "", (), Path("x.beatlog"), PROBE),
            verdict,
            None,
            "no such file" if verdict is Verdict.ERROR else None,
            0.01,
        )
        for n, verdict in enumerate(verdicts)
    ]


def test_a_suite_of_a_screenful_lists_every_dtc() -> None:
    text = plain_text(render_suite(outcomes(MAX_LISTED - 1, failed=1)), width=120)

    assert suite_names(text) == [f"dtc-{n:03}" for n in range(MAX_LISTED)]
    assert "not listed" not in text


def test_a_longer_suite_lists_only_what_did_not_pass_and_counts_the_rest() -> None:
    text = plain_text(render_suite(outcomes(140, failed=2, errors=1)), width=120)

    assert suite_names(text) == ["dtc-140", "dtc-141", "dtc-142"]
    assert text.rstrip().endswith(
        "… and 140 passed, not listed: run with --verbose to list every DTC"
    )


def test_a_longer_suite_that_passes_whole_is_one_line_without_a_table() -> None:
    text = plain_text(render_suite(outcomes(140)), width=120)

    assert text == "140 passed, not listed: run with --verbose to list every DTC\n"


def test_every_dtc_of_a_longer_suite_is_listed_when_asked() -> None:
    text = plain_text(render_suite(outcomes(140, failed=2), every=True), width=120)

    assert suite_names(text) == [f"dtc-{n:03}" for n in range(142)]
    assert "not listed" not in text


def test_dtcs_of_one_name_are_listed_by_their_ids_whole_on_a_narrow_terminal() -> None:
    specs = [
        DtcSpec(
            Path(f"robots/{robot}/dtc/low-battery.dtc.toml"),
            "low-battery",
            "",
            (),
            Path("x"),
            PROBE,
        )
        for robot in ("dog", "rover")
    ]
    shown = [
        SpecOutcome(spec, Verdict.ERROR, None, "no such file", 0.01)
        for spec in distinguished(specs)
    ]

    text = plain_text(render_suite(shown), width=80)

    cells = [line.split("│")[1].strip() for line in text.splitlines() if line.startswith("│")]
    assert "".join(cells) == (
        "robots/dog/dtc/low-battery.dtc.toml::low-battery"
        "robots/rover/dtc/low-battery.dtc.toml::low-battery"
    )


def test_text_in_square_brackets_is_shown_as_written_never_taken_for_markup() -> None:
    error = 'x.beatlog: array draws need numpy: pip install "beatlog[arrays]"'
    (outcome,) = outcomes(0, errors=1)

    text = plain_text(render_suite([dataclasses.replace(outcome, error=error)]), width=200)

    assert table_row(text, "dtc-000") == ["dtc-000", "error", "—", "—", "0.01 s", error]


def test_an_invariant_that_does_not_hold_shows_what_it_saw(record_probe: RecordFn) -> None:
    log = record_probe(300)
    text = plain_text(
        render_replay(replay(log, probe_system(), invariants=[never_close])), width=100
    )
    lines = whole_lines(text)

    assert "first divergence: cycle 35, t = 1.080 s, invariant" in lines[1]
    assert "invariant never_close does not hold: 0.3 m from the pole" in lines
    assert "behavior states after the update" in lines
    assert table_row(text, "near") == ["near", "'near'"]
    assert table_row(text, "speed") == ["speed", "0.0"]


def test_outputs_that_differ_only_in_bits_are_shown_side_by_side(record_probe: RecordFn) -> None:
    result = replay(record_probe(300), probe_system(threshold=0.6))
    assert result.divergence is not None
    bits_only = dataclasses.replace(
        result.divergence,
        kind=DivergenceKind.OUTPUTS,
        expected_outputs={"speed": 0.0},
        actual_outputs={"speed": -0.0},
    )

    text = plain_text(render_replay(dataclasses.replace(result, divergence=bits_only)), width=100)

    assert table_row(text, "speed = 0.0") == ["speed = 0.0", "speed = -0.0"]
