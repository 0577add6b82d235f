"""One DTC's run: its verdict against its system and baseline, its audit, its charts and
its break points."""

from __future__ import annotations

import dataclasses
import re
import sys
from collections.abc import Callable, Iterable
from pathlib import Path

import pytest

from beatlog.baseline.file import expected_path
from beatlog.baseline.policy import SpecOptions, UpdateMode
from beatlog.model.behavior import PriorityArbiter
from beatlog.model.context import Context
from beatlog.replay.verdict import Checked, Divergence, DivergenceKind
from beatlog.report.html import dtc_charts
from beatlog.suite.maintenance import PendingUpdate, UpdateAction, approve, update_baselines
from beatlog.suite.parallel import run_suite
from beatlog.suite.runner import SpecOutcome, Verdict, repeat_note, run_spec
from tests.conftest import Dice, Near, Probe, RecordFn, distances
from tests.factories import cut_short
from tests.specs import CHANGED, FIRST_CHANGED_CYCLE, PROBE, written_dtc
from tests.systems import (
    leaks,
    leaky_system,
    quiet_system,
    record_driver,
    record_session,
    restless_system,
)
from tests.text import svg_texts


@pytest.fixture
def log(record_probe: RecordFn) -> Path:
    return record_probe(300)


def verdicts(outcomes: Iterable[SpecOutcome]) -> list[tuple[str, Verdict]]:
    return [(outcome.spec.name, outcome.verdict) for outcome in outcomes]


# run_spec


def test_a_spec_replayed_against_its_own_system_passes(tmp_path: Path, log: Path) -> None:
    spec = written_dtc(tmp_path, "avoid-pole", log)

    outcome = run_spec(spec)

    assert outcome.spec == spec
    assert outcome.verdict is Verdict.PASSED
    assert outcome.result is not None
    assert (outcome.result.ok, outcome.result.divergence, outcome.result.counts) == (
        True,
        None,
        {"cycles": 300, "state_changes": 45, "outputs": 453, "draws": 60, "samples": 0},
    )
    assert outcome.result.cycles == 300
    assert outcome.error is None
    assert outcome.wall_time_s > 0


def test_a_changed_system_fails_at_the_first_divergence(tmp_path: Path, log: Path) -> None:
    outcome = run_spec(written_dtc(tmp_path, "avoid-pole", log, CHANGED))

    assert outcome.verdict is Verdict.FAILED
    assert outcome.result is not None
    assert (outcome.result.ok, outcome.result.divergent_cycles) == (False, 1)
    divergence = outcome.result.divergence
    assert divergence is not None
    assert divergence.cycle == FIRST_CHANGED_CYCLE
    assert divergence.kind is DivergenceKind.STATE_CHANGES
    assert outcome.error is None


def test_a_dtc_whose_system_draws_at_set_up_passes_and_fails_at_set_up(
    tmp_path: Path,
) -> None:
    log = record_driver(tmp_path / "driver.beatlog")

    passed = run_spec(
        written_dtc(tmp_path, "drive", log, "tests.systems:driver_system"),
        SpecOptions(timelines=True),
    )
    failed = run_spec(
        written_dtc(tmp_path, "drive-more", log, "tests.systems:driver_system_drawing_more"),
        SpecOptions(update=UpdateMode.NEW),
    )

    assert passed.verdict is Verdict.PASSED
    assert [timeline.cycles for timeline in passed.timelines] == [20]
    assert failed.verdict is Verdict.FAILED
    assert failed.result is not None
    divergence = failed.result.divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.SETUP
    assert failed.update_refused == (
        "a divergence in set-up draws cannot be re-baselined: re-record the session"
    )


def test_a_missing_log_is_an_error_that_says_where_a_spec_s_log_is_looked_for(
    tmp_path: Path,
) -> None:
    spec = written_dtc(tmp_path, "lost", tmp_path / "lost.beatlog")

    outcome = run_spec(spec)

    assert outcome.verdict is Verdict.ERROR
    assert outcome.result is None
    assert outcome.error == (
        f"{tmp_path / 'lost.beatlog'}: no such file (a spec's log is relative to its folder)"
    )


def test_a_window_past_the_logs_end_is_an_error_of_the_spec(tmp_path: Path, log: Path) -> None:
    spec = written_dtc(tmp_path, "long", log, start_cycle=10, end_cycle=300)

    outcome = run_spec(spec)

    assert outcome.verdict is Verdict.ERROR
    assert outcome.error == f"{spec.path}: end_cycle 300 is past the log's last cycle (299)"


def test_a_windowed_spec_is_judged_in_its_window_alone(tmp_path: Path, log: Path) -> None:
    spec = written_dtc(tmp_path, "window", log, CHANGED, start_cycle=30, end_cycle=60)

    outcome = run_spec(spec)

    assert outcome.verdict is Verdict.PASSED
    assert outcome.result is not None
    assert outcome.result.cycles == 31
    assert outcome.reproduce == f"beatlog test {spec.path}"


def test_a_system_that_cannot_be_imported_is_an_error(tmp_path: Path, log: Path) -> None:
    outcome = run_spec(written_dtc(tmp_path, "ghost", log, "tests.no_such_module:system"))

    assert outcome.verdict is Verdict.ERROR
    assert outcome.result is None
    assert outcome.error is not None
    assert outcome.error.startswith("'tests.no_such_module:system': cannot import")


def test_a_truncated_log_passes_only_when_the_spec_allows_it(
    tmp_path: Path, record_chunked: RecordFn
) -> None:
    """A log cut off mid-session (the robot lost power) keeps its complete cycles."""
    log = record_chunked(300)
    data = log.read_bytes()
    log.write_bytes(data[: len(data) // 2])

    strict = run_spec(written_dtc(tmp_path, "strict", log))
    lenient = run_spec(written_dtc(tmp_path, "lenient", log, allow_truncated=True))

    assert strict.verdict is Verdict.FAILED
    assert strict.result is not None
    assert strict.result.divergence is not None
    assert strict.result.divergence.kind is DivergenceKind.LOG_ENDED
    assert lenient.verdict is Verdict.PASSED
    assert lenient.result is not None
    assert 0 < lenient.result.cycles < 300


def test_a_dtc_that_checks_nothing_is_an_error_unless_its_spec_intends_it(
    tmp_path: Path,
) -> None:
    log = record_session(tmp_path / "quiet.beatlog", quiet_system())
    quiet = "tests.systems:quiet_system"

    empty = run_spec(written_dtc(tmp_path, "empty", log, quiet))
    intended = run_spec(written_dtc(tmp_path, "intended", log, quiet, allow_empty=True))

    assert (empty.verdict, empty.result) == (Verdict.ERROR, None)
    assert empty.error == (
        f"{log}: the replay checked nothing (20 cycles but no state change, output, draw or "
        "sample); if nothing is meant to happen in it, accept it with --allow-empty (in a "
        "spec: allow_empty = true)"
    )
    assert intended.verdict is Verdict.PASSED
    assert intended.result is not None
    assert (intended.result.cycles, intended.result.checked) == (20, Checked())


def test_timelines_for_reports_are_gathered_only_when_asked(tmp_path: Path, log: Path) -> None:
    passing = written_dtc(tmp_path, "avoid-pole", log)
    failing = written_dtc(tmp_path, "avoid-pole-earlier", log, CHANGED)
    lost = written_dtc(tmp_path, "lost", tmp_path / "lost.beatlog")

    assert run_spec(passing).timelines == ()
    (whole,) = dtc_charts("avoid-pole", run_spec(passing, SpecOptions(timelines=True)).timelines)
    close_up, whole_failing = dtc_charts(
        "avoid-pole-earlier", run_spec(failing, SpecOptions(timelines=True)).timelines
    )
    assert run_spec(lost, SpecOptions(timelines=True)).timelines == ()

    divergence = f"first divergence: cycle {FIRST_CHANGED_CYCLE}, t = 0.660 s (state changes)"
    assert svg_texts(whole.svg)[:2] == [
        "avoid-pole: the whole session, 300 cycles, 9.0 s",
        "behavior states",
    ]
    assert svg_texts(close_up.svg)[:2] == [
        "avoid-pole-earlier: close-up of the first divergence, 0.000–3.660 s",
        divergence,
    ]
    assert svg_texts(whole_failing.svg)[:2] == [
        "avoid-pole-earlier: the whole session, 300 cycles, 9.0 s",
        divergence,
    ]
    assert {"far", "near"} <= set(close_up.states) <= set(whole_failing.states)


# the determinism audit


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_each_worker_audits_its_spec_when_asked(tmp_path: Path, log: Path) -> None:
    leaky_log = record_session(tmp_path / "leaky.beatlog", leaky_system())
    specs = tmp_path / "specs"
    suite = [
        written_dtc(specs, "leaky", leaky_log, "tests.systems:leaky_system"),
        written_dtc(specs, "probe", log),
        written_dtc(specs, "lost", tmp_path / "lost.beatlog"),
    ]

    unaudited = run_spec(suite[0])
    leaky, probe, lost = run_suite(suite, jobs=2, audit=True)

    assert unaudited.audit is None
    assert unaudited.audit_findings == 0
    assert verdicts([leaky, probe, lost]) == [
        ("leaky", Verdict.PASSED),  # the verdict is the replay's; the audit is apart
        ("probe", Verdict.PASSED),
        ("lost", Verdict.ERROR),
    ]
    assert leaky.audit is not None
    assert [finding.call for finding in leaky.audit.findings] == [call for call, _ in leaks()]
    assert leaky.audit_findings == len(leaks())
    assert probe.audit is not None
    assert (probe.audit.findings, probe.audit.hash_seed_dependence) == ((), None)
    assert lost.audit is None


class CountingArbiter(PriorityArbiter[Probe]):
    """The probe system (changed, by default), counting how often a replay starts (cycle
    0 is stepped)."""

    replays = 0

    def __init__(self, threshold: float = 0.6) -> None:
        super().__init__([Near(threshold), Dice()], robot_state=Probe)

    def update(self, state: Probe, context: Context) -> None:
        if context.cycle == 0:
            CountingArbiter.replays += 1
        super().update(state, context)


def counting_system() -> CountingArbiter:
    return CountingArbiter()


def counting_passing_system() -> CountingArbiter:
    return CountingArbiter(threshold=0.5)


def test_a_passing_dtc_is_charted_from_its_verdicts_own_replay(tmp_path: Path, log: Path) -> None:
    spec = written_dtc(tmp_path, "counted", log, "tests.suite.test_runner:counting_passing_system")
    CountingArbiter.replays = 0

    outcome = run_spec(spec, SpecOptions(timelines=True))

    assert outcome.verdict is Verdict.PASSED
    assert len(outcome.timelines) == 1
    assert CountingArbiter.replays == 1


def test_a_failed_dtc_is_replayed_three_times_at_most_for_every_report(
    tmp_path: Path, log: Path
) -> None:
    spec = written_dtc(tmp_path, "counted", log, "tests.suite.test_runner:counting_system")
    CountingArbiter.replays = 0

    outcome = run_spec(spec, SpecOptions(update=UpdateMode.NEW, timelines=True))

    assert outcome.verdict is Verdict.FAILED
    assert outcome.result is not None
    assert outcome.result.divergence is not None
    assert outcome.result.divergence.fields_read == ("distance",)
    assert outcome.update is not None
    assert len(outcome.timelines) == 2
    assert CountingArbiter.replays == 3  # the verdict's, its repeat, and its details'


def files_opened(path: Path, run: Callable[[], object]) -> int:
    """How many times ``run`` opens the file at ``path``, as the interpreter's audit
    events tell (every ``open`` of a file, whoever calls it)."""
    opened: list[str] = []
    watching = [True]
    target = str(path)

    def hook(event: str, args: tuple[object, ...]) -> None:
        if watching[0] and event == "open" and args and str(args[0]) == target:
            opened.append(target)

    sys.addaudithook(hook)  # a hook cannot be removed: it stops listening instead
    try:
        run()
    finally:
        watching[0] = False
    return len(opened)


@pytest.mark.parametrize(
    ("system", "update", "verdict"),
    [
        (PROBE, UpdateMode.NONE, Verdict.PASSED),
        (CHANGED, UpdateMode.NONE, Verdict.FAILED),
        (CHANGED, UpdateMode.NEW, Verdict.FAILED),
    ],
    ids=["passing", "failing", "failing under --update"],
)
def test_a_dtc_opens_its_log_once(
    tmp_path: Path, log: Path, system: str, update: UpdateMode, verdict: Verdict
) -> None:
    spec = written_dtc(tmp_path, "counted", log, system)
    outcomes: list[SpecOutcome] = []

    opened = files_opened(log, lambda: outcomes.append(run_spec(spec, SpecOptions(update=update))))

    assert outcomes[0].verdict is verdict
    assert opened == 1


def test_a_dtc_of_a_log_cut_off_opens_it_once(tmp_path: Path, record_probe: RecordFn) -> None:
    cut = cut_short(record_probe(300, flush_interval_s=1.0))
    spec = written_dtc(tmp_path, "cut", cut, CHANGED, allow_truncated=True)
    outcomes: list[SpecOutcome] = []

    opened = files_opened(
        cut, lambda: outcomes.append(run_spec(spec, SpecOptions(update=UpdateMode.NEW)))
    )

    assert (outcomes[0].verdict, outcomes[0].update is not None) == (Verdict.FAILED, True)
    assert opened == 1


def test_a_dtc_passing_against_its_baseline_opens_its_log_once(tmp_path: Path, log: Path) -> None:
    spec = written_dtc(tmp_path, "counted", log, CHANGED)
    update_baselines([run_spec(spec, SpecOptions(update=UpdateMode.NEW))], UpdateMode.NEW)
    approve([spec.path])
    outcomes: list[SpecOutcome] = []

    opened = files_opened(log, lambda: outcomes.append(run_spec(spec)))

    assert (outcomes[0].verdict, outcomes[0].baseline) == (Verdict.PASSED, expected_path(spec.path))
    assert opened == 1


def test_a_pending_baseline_is_weighed_without_opening_its_log_again(
    tmp_path: Path, log: Path
) -> None:
    spec = written_dtc(tmp_path, "counted", log, CHANGED)
    updates: list[PendingUpdate] = []

    def run() -> None:
        outcome = run_spec(spec, SpecOptions(update=UpdateMode.NEW))
        updates.extend(update_baselines([outcome], UpdateMode.NEW))

    opened = files_opened(log, run)

    assert [update.action for update in updates] == [UpdateAction.WRITTEN]
    assert opened == 1


def test_a_baseline_approved_for_another_recording_is_refused_after_its_one_read(
    tmp_path: Path, log: Path, record_probe: RecordFn
) -> None:
    spec = written_dtc(tmp_path, "counted", log, CHANGED)
    update_baselines([run_spec(spec, SpecOptions(update=UpdateMode.NEW))], UpdateMode.NEW)
    approve([spec.path])
    log.write_bytes(record_probe(300, name="other.beatlog", seed=8).read_bytes())
    outcomes: list[SpecOutcome] = []

    opened = files_opened(log, lambda: outcomes.append(run_spec(spec)))

    assert outcomes[0].verdict is Verdict.ERROR
    assert outcomes[0].error == (
        f"{expected_path(spec.path)}: approved for another recording than {log.name}; delete it"
    )
    assert opened == 1


# break points


def test_a_break_at_a_cycle_stops_the_dtc_there(
    tmp_path: Path, log: Path, breaks: list[dict[str, object]]
) -> None:
    outcome = run_spec(written_dtc(tmp_path, "avoid-pole", log), SpecOptions(break_at=40))

    assert outcome.verdict is Verdict.PASSED
    assert [stop["cycle"] for stop in breaks] == [40]


def test_a_break_past_the_end_of_a_dtcs_log_is_noted(
    tmp_path: Path, record_probe: RecordFn, breaks: list[dict[str, object]]
) -> None:
    cut = cut_short(record_probe(300, flush_interval_s=1.0))
    spec = written_dtc(tmp_path, "cut", cut, allow_truncated=True)

    outcome = run_spec(spec, SpecOptions(break_at=1000))

    assert outcome.verdict is Verdict.PASSED
    assert outcome.result is not None
    assert outcome.result.notes == (
        "the break at cycle 1000 was never reached: the log has only 300 cycles",
    )
    assert breaks == []


def test_a_break_on_divergence_stops_a_failing_dtc_at_its_first_divergence(
    tmp_path: Path, log: Path, breaks: list[dict[str, object]]
) -> None:
    options = SpecOptions(break_on_divergence=True)

    passed = run_spec(written_dtc(tmp_path, "as-recorded", log), options)
    failed = run_spec(written_dtc(tmp_path, "changed", log, CHANGED), options)

    assert (passed.verdict, failed.verdict) == (Verdict.PASSED, Verdict.FAILED)
    assert [stop["cycle"] for stop in breaks] == [FIRST_CHANGED_CYCLE]


def test_break_points_replay_every_spec_in_this_process_whatever_the_jobs(
    tmp_path: Path, log: Path, breaks: list[dict[str, object]]
) -> None:
    specs = [written_dtc(tmp_path, name, log, CHANGED) for name in ("first", "second")]

    outcomes = run_suite(specs, jobs=2, break_on_divergence=True)

    assert verdicts(outcomes) == [("first", Verdict.FAILED), ("second", Verdict.FAILED)]
    assert [stop["cycle"] for stop in breaks] == [FIRST_CHANGED_CYCLE] * 2


def test_a_failure_that_moves_between_runs_says_so_and_points_to_the_audit(
    tmp_path: Path,
) -> None:
    log = record_session(tmp_path / "restless.beatlog", restless_system(), cycles=20)
    spec = written_dtc(tmp_path, "restless", log, "tests.systems:restless_system")

    outcome = run_spec(spec)

    assert outcome.result is not None
    divergence = outcome.result.divergence
    assert divergence is not None
    (note,) = outcome.result.notes
    assert re.fullmatch(
        rf"fails (at a different cycle each run \({divergence.cycle}, then \d+\)"
        rf"|otherwise each run at cycle {divergence.cycle}) on unchanged code: the behaviors "
        rf"are not deterministic; run `beatlog test --audit {re.escape(str(spec.path))}` "
        "to find the call",
        note,
    )


def test_a_failure_that_repeats_itself_says_nothing_more(tmp_path: Path, log: Path) -> None:
    outcome = run_spec(written_dtc(tmp_path, "avoid-pole", log, CHANGED))

    assert outcome.result is not None
    assert outcome.result.divergence is not None
    assert outcome.result.notes == ()


# invariants

CHECKS = '''
def never_close(cycle):
    if cycle.robot_state.distance <= 0.3:
        raise AssertionError(f"{cycle.robot_state.distance} m from the pole")


def near_late(cycle):
    """Holds on the probe; not on the changed probe, whose near goes near sooner."""
    if cycle.states["near"] == "near":
        assert cycle.robot_state.distance < 0.5, "near too soon"
'''
"""Invariants of the probe, beside the specs that name them (``checks:never_close``)."""

FIRST_CLOSE = next(t for t, d in enumerate(distances(300)) if d <= 0.3)


def test_a_dtc_fails_at_the_first_cycle_its_invariants_do_not_hold(
    tmp_path: Path, log: Path
) -> None:
    (tmp_path / "checks.py").write_text(CHECKS, encoding="utf-8")
    spec = written_dtc(tmp_path, "checked", log, invariants=["checks:never_close"])

    outcome = run_spec(spec)

    assert outcome.verdict is Verdict.FAILED
    assert outcome.result is not None
    divergence = outcome.result.divergence
    assert divergence is not None
    assert (divergence.kind, divergence.cycle, divergence.invariant) == (
        DivergenceKind.INVARIANT,
        FIRST_CLOSE,
        "never_close",
    )
    assert outcome.result.reproduce == f"beatlog test {spec.path}"
    assert outcome.result.notes == ()  # the failure repeats in a fresh replay


def test_the_invariants_judge_the_cycles_a_baseline_runs_open_loop(
    tmp_path: Path, log: Path
) -> None:
    spec = written_dtc(tmp_path, "retuned", log, CHANGED)
    update_baselines([run_spec(spec, SpecOptions(update=UpdateMode.NEW))], UpdateMode.NEW)
    approve([spec.path])
    (tmp_path / "checks.py").write_text(CHECKS, encoding="utf-8")
    checked = written_dtc(tmp_path, "retuned", log, CHANGED, invariants=["checks:near_late"])

    outcome = run_spec(checked)

    assert outcome.baseline == expected_path(spec.path)
    assert outcome.result is not None
    divergence = outcome.result.divergence
    assert divergence is not None
    assert (divergence.kind, divergence.cycle) == (DivergenceKind.INVARIANT, FIRST_CHANGED_CYCLE)
    assert divergence.message == "invariant near_late does not hold: near too soon"


def test_an_invariant_that_does_not_import_is_an_error_of_the_dtc(
    tmp_path: Path, log: Path
) -> None:
    (tmp_path / "checks.py").write_text(CHECKS, encoding="utf-8")
    spec = written_dtc(tmp_path, "checked", log, invariants=["checks:never_far"])

    outcome = run_spec(spec)

    assert outcome.verdict is Verdict.ERROR
    assert (
        outcome.error == "'checks:never_far': checks has no never_far (did you mean 'never_close'?)"
    )


def test_a_project_invariant_that_does_not_import_names_the_pyproject(
    tmp_path: Path, log: Path
) -> None:
    pyproject = tmp_path / "pyproject.toml"
    pyproject.write_text('[tool.beatlog]\ninvariants = ["checks:gone"]\n', encoding="utf-8")
    (tmp_path / "checks.py").write_text(CHECKS, encoding="utf-8")

    outcome = run_spec(written_dtc(tmp_path / "specs", "checked", log))

    assert outcome.verdict is Verdict.ERROR
    assert outcome.error == (
        f"'checks:gone': checks has no gone (listed under [tool.beatlog] invariants in {pyproject})"
    )


# whether a failure repeats


FIRST = Divergence(kind=DivergenceKind.OUTPUTS, cycle=12, time_ns=360, message="outputs differ")
AUDIT = "beatlog test --audit a.dtc.toml"


def test_a_failure_that_repeats_itself_has_no_note() -> None:
    assert repeat_note(FIRST, dataclasses.replace(FIRST, message="as before"), AUDIT) == ()


def test_a_failure_that_moves_or_passes_the_next_time_points_to_the_audit() -> None:
    moved = dataclasses.replace(FIRST, cycle=14)
    otherwise = dataclasses.replace(FIRST, actual_outputs={"speed": float("nan")})

    notes = [repeat_note(FIRST, again, AUDIT) for again in (None, moved, otherwise)]

    assert [note[0].split(" on unchanged code")[0] for note in notes] == [
        "fails at cycle 12 in one run and passes in the next",
        "fails at a different cycle each run (12, then 14)",
        "fails otherwise each run at cycle 12",
    ]
    assert all(note[0].endswith(f"run `{AUDIT}` to find the call") for note in notes)
