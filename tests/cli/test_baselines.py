"""The re-baselining workflow from the command line: update, review, approve — and the
promises around it: a failure never overwrites an accepted baseline, CI never writes."""

from __future__ import annotations

import io
import os
import re
from pathlib import Path

import pytest
from rich.console import Console

from beatlog.cli.baselines import review
from beatlog.suite.baseline import expected_path, pending_path, read_baseline
from tests.commands import Beatlog, assert_error, at_a_terminal
from tests.conftest import RecordFn
from tests.factories import fill_the_disk_after
from tests.specs import CHANGED, FIRST_CHANGED_CYCLE, write_spec
from tests.text import table_row, whole_lines

AGAIN = "tests.systems:probe_system_changed_again"

pytestmark = pytest.mark.usefixtures("outside_ci", "wide_plain_console")


@pytest.fixture
def spec(tmp_path: Path, record_probe: RecordFn) -> Path:
    """A spec whose behaviors changed on purpose since the recording."""
    return write_spec(tmp_path / "specs", "avoid-pole", record_probe(300), CHANGED)


def test_update_writes_a_pending_file_and_approve_makes_it_the_baseline(
    beatlog: Beatlog, spec: Path
) -> None:
    updated = beatlog("test", "--update", spec)
    assert updated.code == 1
    assert (
        f"pending {pending_path(spec)} (16 state changes, 12 output changes, open loop since "
        f"cycle {FIRST_CHANGED_CYCLE} (0.660 s)): review with beatlog review {spec}, accept with "
        f"beatlog approve {spec}"
    ) in whole_lines(updated.out)
    assert not expected_path(spec).exists()
    pending = read_baseline(pending_path(spec))
    assert any(change.cycle == FIRST_CHANGED_CYCLE for change in pending.expectation.changes)

    approved = beatlog("approve", spec)
    assert approved.code == 0
    assert f"approved avoid-pole: {expected_path(spec)}" in whole_lines(approved.out)
    assert not pending_path(spec).exists()
    assert read_baseline(expected_path(spec)).expectation.changes == pending.expectation.changes

    rerun = beatlog("test", spec)
    assert rerun.code == 0, rerun.out
    assert table_row(rerun.out, "avoid-pole")[:2] == [
        "avoid-pole",
        f"passed (approved baseline, open loop since cycle {FIRST_CHANGED_CYCLE})",
    ]


def test_an_update_on_a_full_disk_is_one_line_and_exit_2(
    beatlog: Beatlog, spec: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    fill_the_disk_after(monkeypatch, files=0)

    updated = beatlog("test", "--update", spec)

    assert (updated.code, updated.err) == (
        2,
        f"beatlog: error: {pending_path(spec)}: cannot write: No space left on device\n",
    )
    assert sorted(path.name for path in spec.parent.iterdir()) == [spec.name]


def test_a_failing_run_never_overwrites_the_accepted_baseline(beatlog: Beatlog, spec: Path) -> None:
    beatlog("test", "--update", spec)
    beatlog("approve", spec)
    accepted = expected_path(spec).read_bytes()
    write_spec(spec.parent, "avoid-pole", spec.parent.parent / "probe.beatlog", AGAIN)

    failed = beatlog("test", "--update", spec)

    assert failed.code == 1
    assert "behavior state changes differ from the approved baseline" in whole_lines(failed.out)
    assert expected_path(spec).read_bytes() == accepted
    assert pending_path(spec).exists()


def test_nothing_is_written_when_ci_is_set(
    beatlog: Beatlog, spec: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("CI", "true")

    updated = beatlog("test", "--update", spec)
    assert updated.code == 1
    assert "CI is set: no pending baselines written" in whole_lines(updated.out)
    assert not pending_path(spec).exists()

    monkeypatch.delenv("CI")
    beatlog("test", "--update", spec)
    waiting = pending_path(spec).read_bytes()
    monkeypatch.setenv("CI", "1")
    assert_error(beatlog("approve", spec), "CI is set: beatlog never writes baselines in CI")
    assert pending_path(spec).read_bytes() == waiting
    assert not expected_path(spec).exists()


def test_a_stale_pending_file_goes_when_the_dtc_passes(
    beatlog: Beatlog, spec: Path, record_probe: RecordFn
) -> None:
    beatlog("test", "--update", spec)
    write_spec(spec.parent, "avoid-pole", spec.parent.parent / "probe.beatlog")  # change undone

    run = beatlog("test", "--update", spec)

    assert run.code == 0
    assert f"removed stale {pending_path(spec)}: avoid-pole passes" in whole_lines(run.out)
    assert not pending_path(spec).exists()


def test_approve_without_anything_pending_is_a_usage_error(beatlog: Beatlog, spec: Path) -> None:
    assert_error(
        beatlog("approve", spec),
        f"{spec}: nothing pending to approve (run 'beatlog test --update' first)",
    )


def test_review_shows_the_change_as_a_diff_and_leaves_it_without_a_terminal(
    beatlog: Beatlog, spec: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("sys.stdin", io.StringIO(""))  # no terminal, nothing piped
    beatlog("test", "--update", spec)
    waiting = pending_path(spec).read_bytes()

    run = beatlog("review", spec.parent)

    assert run.code == 0
    assert "208 state and output changes recorded (probe.beatlog) → 178 pending" in whole_lines(
        run.out
    )
    assert run.out.splitlines()[2:22] == [
        f"open loop since cycle {FIRST_CHANGED_CYCLE} (0.660 s)",
        "--- recorded (probe.beatlog)",
        "+++ pending",
        "@@ -26,11 +26,6 @@",
        '       20     0.630  output "time" = 0.630021',
        '-      21     0.660  output "time" = 0.660021',
        '-      22     0.690  output "time" = 0.690022',
        '-      23     0.720  output "time" = 0.720024',
        '-      24     0.750  output "time" = 0.750024',
        '-      25     0.780  output "time" = 0.780025',
        '-      26     0.810  "arbiter": "dice" -> "near"',
        '-      26     0.810  "near": "far" -> "near"',
        '-      26     0.810  output "speed" = 0.0',
        '-      26     0.810  output "time" absent',
        '+      21     0.660  "arbiter": "dice" -> "near"',
        '+      21     0.660  "near": "far" -> "near"',
        '+      21     0.660  output "speed" = 0.0',
        '+      21     0.660  output "time" absent',
        '       35     1.080  "dice": "odd" -> "even"',
        "@@ -39,11 +34,6 @@",
    ]
    assert f"left pending: accept with beatlog approve {spec}" in whole_lines(run.out)
    assert pending_path(spec).read_bytes() == waiting


@pytest.mark.parametrize(("answer", "accepted"), [("accept", True), ("reject", False)])
def test_review_accepts_or_rejects_what_the_reviewer_says(
    beatlog: Beatlog, spec: Path, answer: str, *, accepted: bool
) -> None:
    beatlog("test", "--update", spec)
    questions: list[str] = []

    def ask(question: str) -> str:
        questions.append(question)
        return answer

    counts = review([spec.parent], Console(width=200), ask=ask)

    assert questions == ["accept the new expectation of avoid-pole?"]
    assert counts == ((1, 0, 0) if accepted else (0, 1, 0))
    assert not pending_path(spec).exists()
    assert expected_path(spec).exists() is accepted


def test_orphaned_baselines_are_named(beatlog: Beatlog, spec: Path) -> None:
    beatlog("test", "--update", spec)
    beatlog("approve", spec)
    orphan = spec.with_name("renamed-away.dtc.expected")
    expected_path(spec).rename(orphan)

    run = beatlog("test", spec.parent)

    assert f"orphaned baseline {orphan}: no spec beside it; delete it" in whole_lines(run.out)


def test_a_baseline_made_from_another_recording_is_an_error(
    beatlog: Beatlog, spec: Path, record_probe: RecordFn
) -> None:
    beatlog("test", "--update", spec)
    beatlog("approve", spec)
    record_probe(200, name="rerecorded.beatlog").replace(spec.parent.parent / "probe.beatlog")

    run = beatlog("test", spec)

    assert run.code == 2
    assert run.err == (
        f"beatlog: error: avoid-pole ({spec}): {expected_path(spec)}: approved for another "
        "recording than probe.beatlog; delete it\n"
    )


def test_a_divergence_in_random_numbers_is_rebaselined_and_its_draws_approved(
    beatlog: Beatlog, spec: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    write_spec(spec.parent, "avoid-pole", spec.parent.parent / "probe.beatlog",
               "tests.systems:probe_system_greedy")  # fmt: skip
    assert beatlog("test", spec).code == 1

    updated = beatlog("test", "--update", spec)
    monkeypatch.setattr("sys.stdin", io.StringIO("skip\n"))
    reviewed = beatlog("review", spec)
    approved = beatlog("approve", spec)
    judged = beatlog("test", spec)

    assert updated.code == 1
    # the greedy system's new draws are live: how many changes follow them, and from
    # which cycle, vary from run to run
    loop = r"open loop since cycle \d+ \(\d+\.\d{3} s\)"
    (pending,) = [line for line in whole_lines(updated.out) if line.startswith("pending ")]
    assert re.fullmatch(
        rf"pending {re.escape(str(pending_path(spec)))} \(\d+ state changes, 0 output changes, "
        rf"60 draws made otherwise, {loop}\): "
        + re.escape(f"review with beatlog review {spec}, accept with beatlog approve {spec}"),
        pending,
    ), pending
    head = "\n".join(reviewed.out.splitlines()[1:4])
    assert re.fullmatch(
        r"208 state and output changes recorded \(probe\.beatlog\) → \d+ pending\n"
        rf"draws dice: 60 new draws of randint\(1, 6\)\n{loop}",
        head,
    ), head
    assert approved.code == 0
    assert judged.code == 0, judged.out
    draws = [line for line in expected_path(spec).read_text().splitlines() if line[:6] == "draws "]
    every_5th = " ".join(str(cycle) for cycle in range(0, 300, 5))
    assert draws == [f'draws "dice": - -> randint(1, 6) in cycles {every_5th}']


@pytest.mark.parametrize(
    ("planted", "problem"),
    [
        (
            "tests.systems:probe_system_greedier",
            "dice called randint(1, 6), a draw the recording does not have, which the "
            "approved baseline does not hold in this cycle",
        ),
        (
            "tests.systems:probe_system_greedy_wide",
            "dice called randint(1, 8) where randint(1, 6) was recorded, which the approved "
            "baseline does not hold",
        ),
        (
            "tests.conftest:probe_system",
            # the first cycle whose last roll had the other parity than its first (the
            # probe's log is recorded afresh), else the cycle the roll is missing from
            "behavior state changes differ from the approved baseline|dice did not make "
            "the draw the approved baseline holds: a new randint(1, 6)",
        ),
    ],
)
def test_a_rebaselined_draw_change_still_catches_a_planted_bug(
    beatlog: Beatlog, spec: Path, planted: str, problem: str
) -> None:
    log = spec.parent.parent / "probe.beatlog"
    write_spec(spec.parent, "avoid-pole", log, "tests.systems:probe_system_greedy")
    beatlog("test", "--update", spec)
    beatlog("approve", spec)

    write_spec(spec.parent, "avoid-pole", log, planted)
    run = beatlog("test", spec)

    assert run.code == 1
    assert any(one in " ".join(run.out.split()) for one in problem.split("|"))


def test_a_renamed_behavior_gets_a_rename_proposal_and_the_spec_rename_fixes_it(
    beatlog: Beatlog, spec: Path
) -> None:
    log = spec.parent.parent / "probe.beatlog"
    write_spec(spec.parent, "avoid-pole", log, "tests.conftest:probe_system_renamed")

    failed = beatlog("test", spec)
    assert failed.code == 1
    assert "The whole trace differs only by renamed behaviors: near → close" in whole_lines(
        failed.out
    )
    assert 'If intended, add to the spec: renames = { "near" = "close" }' in whole_lines(failed.out)

    write_spec(spec.parent, "avoid-pole", log, "tests.conftest:probe_system_renamed",
               renames={"near": "close"})  # fmt: skip
    assert beatlog("test", spec).code == 0


@pytest.mark.parametrize(("piped", "accepted"), [("a\n", True), ("REJ\n", False)])
def test_review_reads_piped_answers_and_takes_the_start_of_a_word(
    beatlog: Beatlog, spec: Path, monkeypatch: pytest.MonkeyPatch, piped: str, *, accepted: bool
) -> None:
    beatlog("test", "--update", spec)
    monkeypatch.setattr("sys.stdin", io.StringIO(piped))

    run = beatlog("review", spec.parent)

    assert run.code == 0
    assert not pending_path(spec).exists()
    assert expected_path(spec).exists() is accepted


def test_review_at_a_terminal_asks_again_until_an_answer_names_a_decision(
    beatlog: Beatlog, spec: Path
) -> None:
    beatlog("test", "--update", spec)
    waiting = pending_path(spec).read_bytes()
    environment = {key: value for key, value in os.environ.items() if key != "CI"}
    review_command: list[str | Path] = ["-m", "beatlog.cli.main", "review", spec.parent]
    with at_a_terminal(review_command, env=environment) as terminal:
        first = terminal.until("[a]ccept/[r]eject/[s]kip")
        again = terminal.type("maybe", until="[a]ccept/[r]eject/[s]kip")
        rest = terminal.type("A", until="accepted")
        code = terminal.program.wait(timeout=60)

    assert "accept the new expectation of avoid-pole? [a]ccept/[r]eject/[s]kip:" in whole_lines(
        first
    )
    assert "maybe" in whole_lines(again)
    assert f"accepted {expected_path(spec)}" in whole_lines(rest)
    assert code == 0
    assert expected_path(spec).read_bytes() == waiting
    assert not pending_path(spec).exists()
