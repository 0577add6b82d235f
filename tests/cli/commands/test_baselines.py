"""The re-baselining workflow from the command line: update, review, approve — and the
promises around it: a failure never overwrites an accepted baseline, CI never writes;
and ``upgrade-baselines``: older baselines rewritten in format 7, each named, which
``review`` and ``approve`` refuse in one line that names the command."""

from __future__ import annotations

import io
import os
import re
from pathlib import Path

import pytest
from rich.console import Console

from beatlog.baseline.file import expected_path, pending_path, read_baseline
from beatlog.cli.commands.baselines import review
from tests.commands import Beatlog, assert_error, at_a_terminal
from tests.conftest import RecordFn
from tests.factories import fill_the_disk_after
from tests.specs import BASELINE_MAGIC, CHANGED, FIRST_CHANGED_CYCLE, write_spec
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
        f"pending {pending_path(spec)} (0 state changes lost, 0 new, 12 moved, 12 output changes, "
        f"open loop since cycle {FIRST_CHANGED_CYCLE} (0.660 s), closed loop for "
        f"{FIRST_CHANGED_CYCLE} of 300 cycles (7 %)): review with beatlog review {spec}, "
        f"accept with beatlog approve {spec}"
    ) in whole_lines(updated.out)
    assert not expected_path(spec).exists()
    pending = read_baseline(pending_path(spec)).whole  # read before approve moves it
    assert any(change.cycle == FIRST_CHANGED_CYCLE for change in pending.changes)

    approved = beatlog("approve", spec)
    assert approved.code == 0
    assert f"approved avoid-pole: {expected_path(spec)}" in whole_lines(approved.out)
    assert not pending_path(spec).exists()
    assert read_baseline(expected_path(spec)).whole.changes == pending.changes

    rerun = beatlog("test", spec)
    assert rerun.code == 0, rerun.out
    assert table_row(rerun.out, "avoid-pole")[:2] == [
        "avoid-pole",
        f"passed (approved baseline, open loop since cycle {FIRST_CHANGED_CYCLE})",
    ]


def test_review_and_approve_print_a_path_with_brackets_as_it_is(
    beatlog: Beatlog, tmp_path: Path, record_probe: RecordFn, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = record_probe(300)
    spec = write_spec(tmp_path / "[red]specs[/]", "avoid-pole", log, CHANGED)
    other = write_spec(tmp_path / "[bold]more", "avoid-pole", log, CHANGED)
    assert beatlog("test", "--update", spec, other).code == 1
    monkeypatch.setattr("sys.stdin", io.StringIO("a\n"))

    reviewed = beatlog("review", spec)
    approved = beatlog("approve", other)

    assert f"accepted {expected_path(spec)}" in whole_lines(reviewed.out)
    assert f"approved avoid-pole: {expected_path(other)}" in whole_lines(approved.out)


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


def test_approve_after_review_accepted_everything_has_nothing_to_do_and_succeeds(
    beatlog: Beatlog, spec: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The tour's order: review accepts (``a``), then approve finds nothing left."""
    beatlog("test", "--update", spec)
    monkeypatch.setattr("sys.stdin", io.StringIO("a\n"))
    assert beatlog("review", spec).code == 0

    approved = beatlog("approve", spec)

    assert (approved.code, approved.out, approved.err) == (0, "nothing pending to approve\n", "")
    assert expected_path(spec).exists()


def test_review_shows_the_change_as_a_diff_and_leaves_it_without_a_terminal(
    beatlog: Beatlog, spec: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("sys.stdin", io.StringIO(""))  # no terminal, nothing piped
    beatlog("test", "--update", spec)
    waiting = pending_path(spec).read_bytes()

    run = beatlog("review", spec.parent)

    assert run.code == 0
    assert run.out.splitlines()[1:22] == [
        "208 state and output changes recorded (probe.beatlog) → 178 pending: 0 state changes "
        "lost, 0 new, 12 moved",
        f"open loop since cycle {FIRST_CHANGED_CYCLE} (0.660 s): closed loop for "
        f"{FIRST_CHANGED_CYCLE} of 300 cycles (7 %)",
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

    assert questions == ["accept the new baseline of avoid-pole? [a]ccept/[r]eject/[s]kip"]
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
    closed = r"closed loop for \d+ of 300 cycles \(\d+ %\)"
    (pending,) = [line for line in whole_lines(updated.out) if line.startswith("pending ")]
    assert re.fullmatch(
        rf"pending {re.escape(str(pending_path(spec)))} \(\d+ state changes? lost, \d+ new, \d+ "
        rf"moved, 0 output changes, 60 draws made otherwise, {loop}, {closed}\): "
        + re.escape(f"review with beatlog review {spec}, accept with beatlog approve {spec}"),
        pending,
    ), pending
    head = "\n".join(reviewed.out.splitlines()[1:3])
    assert re.fullmatch(
        r"208 state and output changes recorded \(probe\.beatlog\) → \d+ pending: \d+ state "
        rf"changes? lost, \d+ new, \d+ moved\n{loop}: {closed}",
        head,
    ), head
    assert "draws dice: 60 new draws of randint(1, 6)" in whole_lines(reviewed.out)
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

    assert "accept the new baseline of avoid-pole? [a]ccept/[r]eject/[s]kip:" in whole_lines(first)
    assert "maybe" in whole_lines(again)
    assert f"accepted {expected_path(spec)}" in whole_lines(rest)
    assert code == 0
    assert expected_path(spec).read_bytes() == waiting
    assert not pending_path(spec).exists()


BLIND = "tests.systems:probe_system_blind"
NEAR_LOST = (
    '"near": 6 state changes no longer happen (cycles 26, 75, 126, 175, 226, 275); it never '
    "changes state in this DTC any more"
)
ARBITER_LOST = '"arbiter": 6 state changes no longer happen (cycles 26, 75, 126, 175, 226, 275)'


@pytest.fixture
def blind(spec: Path) -> Path:
    """The spec, its near behavior blind since: its state changes are lost."""
    return write_spec(spec.parent, "avoid-pole", spec.parent.parent / "probe.beatlog", BLIND)


def test_update_counts_and_names_the_state_changes_a_change_loses(
    beatlog: Beatlog, blind: Path
) -> None:
    updated = beatlog("test", "--update", blind)

    lines = whole_lines(updated.out)
    (pending,) = [line for line in lines if line.startswith("pending ")]
    assert pending.startswith(
        f"pending {pending_path(blind)} (12 state changes lost, 0 new, 0 moved, 151 output "
        "changes, open loop since cycle 26 (0.810 s), closed loop for 26 of 300 cycles (8 %)): "
    )
    at = lines.index(pending)
    assert lines[at + 1 : at + 3] == [
        f"lost in avoid-pole: {ARBITER_LOST}",
        f"lost in avoid-pole: {NEAR_LOST}",
    ]


@pytest.mark.parametrize(("answers", "accepted"), [("a\ny\ny\n", True), ("a\ny\n\n", False)])
def test_review_asks_about_each_loss_in_its_own_words_and_shows_piped_answers(
    beatlog: Beatlog,
    blind: Path,
    monkeypatch: pytest.MonkeyPatch,
    answers: str,
    *,
    accepted: bool,
) -> None:
    beatlog("test", "--update", blind)
    monkeypatch.setattr("sys.stdin", io.StringIO(answers))

    run = beatlog("review", blind)

    lines = whole_lines(run.out)
    assert [f"lost: {ARBITER_LOST}", f"lost: {NEAR_LOST}"] == lines[3:5]
    last = "y" if accepted else ""
    asked = lines.index("accept the new baseline of avoid-pole? [a]ccept/[r]eject/[s]kip: a")
    assert lines[asked + 1 : asked + 4] == [
        f"{ARBITER_LOST}: accept this loss? [y/N]: y",
        f"{NEAR_LOST}: accept this loss? [y/N]: {last}".rstrip(),
        f"accepted {expected_path(blind)}"
        if accepted
        else f"left pending: a loss was not accepted; accept with beatlog approve {blind}",
    ]
    assert expected_path(blind).exists() is accepted
    assert pending_path(blind).exists() is not accepted


def test_approve_names_each_loss_it_accepts(beatlog: Beatlog, blind: Path) -> None:
    beatlog("test", "--update", blind)

    approved = beatlog("approve", blind.parent)

    assert whole_lines(approved.out) == [
        f"approved avoid-pole: {expected_path(blind)}",
        f"accepted loss in avoid-pole: {ARBITER_LOST}",
        f"accepted loss in avoid-pole: {NEAR_LOST}",
    ]


def test_a_suite_past_its_open_loop_limits_fails_naming_the_sessions_to_re_record(
    beatlog: Beatlog, spec: Path
) -> None:
    write_spec(spec.parent, "untouched", spec.parent.parent / "probe.beatlog")
    beatlog("test", "--update", spec)
    beatlog("approve", spec)
    pyproject = spec.parent.parent / "pyproject.toml"
    pyproject.write_text("[tool.beatlog]\nmax_open_loop_dtcs = 1\n", encoding="utf-8")
    assert beatlog("test", spec.parent).code == 0

    pyproject.write_text("[tool.beatlog]\nmax_open_loop_share = 0.5\n", encoding="utf-8")
    stale = beatlog("test", spec.parent)

    assert stale.code == 1
    assert whole_lines(stale.out)[-3:-1] == [
        "stale suite ([tool.beatlog]): 1 runs open loop for more than 50 % of its cycles "
        "(max_open_loop_share = 0.5)",
        "re-record first: avoid-pole (93 % open loop)",
    ]


def test_a_bad_open_loop_limit_is_a_one_line_error(beatlog: Beatlog, spec: Path) -> None:
    pyproject = spec.parent.parent / "pyproject.toml"
    pyproject.write_text("[tool.beatlog]\nmax_open_loop_dtcs = -1\n", encoding="utf-8")

    assert_error(
        beatlog("test", spec),
        f"{pyproject}: key 'tool.beatlog.max_open_loop_dtcs': expected an integer >= 0",
    )


# upgrade-baselines

LINES = ['      12     0.360  "avoid": "off" -> "turning"', "      15     0.450  no state changes"]


def old_baseline(path: Path, version: int = 5) -> Path:
    """A baseline of format ``version`` at ``path``, for the log ``a.beatlog``."""
    text = "\n".join([BASELINE_MAGIC[version], f"# log a.beatlog sha256 {'0' * 64}", *LINES])
    path.write_text(text + "\n", encoding="utf-8")
    return path


def test_each_older_baseline_is_named_as_it_is_upgraded(beatlog: Beatlog, tmp_path: Path) -> None:
    first = old_baseline(tmp_path / "a.dtc.expected")
    second = old_baseline(tmp_path / "b.dtc.pending")

    run = beatlog("upgrade-baselines", tmp_path)
    again = beatlog("upgrade-baselines", tmp_path)

    assert (run.code, run.out, run.err) == (
        0,
        f"upgraded {first}: format 5 -> 7\nupgraded {second}: format 5 -> 7\n",
        "",
    )
    assert (again.code, again.out) == (0, "no baseline of an older format\n")
    assert read_baseline(first).whole.quiet == ((15, 450_000_000),)


def test_a_damaged_baseline_is_one_line_and_exit_2(beatlog: Beatlog, tmp_path: Path) -> None:
    path = old_baseline(tmp_path / "a.dtc.expected")
    path.write_text(path.read_text(encoding="utf-8") + "  16  0.480  what\n", encoding="utf-8")

    run = beatlog("upgrade-baselines", path)

    assert_error(run, f"{path}: line 5: Expecting value: line 1 column 1 (char 0)")


@pytest.mark.parametrize("command", ["review", "approve"])
def test_review_and_approve_refuse_an_older_pending_baseline(
    beatlog: Beatlog, tmp_path: Path, command: str
) -> None:
    spec = write_spec(tmp_path, "a", "a.beatlog")
    pending = old_baseline(pending_path(spec))

    run = beatlog(command, spec)

    assert_error(
        run,
        f"{pending}: a format 5 baseline: "
        f"run 'beatlog upgrade-baselines {pending}' to rewrite it in format 7",
    )
    assert not expected_path(spec).exists()
