"""The determinism audit: two replays in fresh interpreters with different hash seeds."""

from __future__ import annotations

import dataclasses
import os
import pickle
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from beatlog.audit.replays import Auditors, AuditReport, Finding, audit
from beatlog.errors import BeatlogError
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.verdict import DivergenceKind
from beatlog_examples.rover import record_lockstep
from tests.conftest import RecordFn
from tests.systems import (
    HEADINGS,
    drifter_sites,
    hand_ticked_tree,
    leaks,
    leaky_system,
    record_driver,
    record_session,
    scripted_system,
)

SYSTEMS = "tests.systems"


@pytest.fixture(scope="module")
def auditors() -> Iterator[Auditors]:
    """The audit interpreters the audits of this module share, as a suite run's do."""
    with Auditors() as kept:
        yield kept


SYSTEMS_FILE = str(Path(__file__).parent.parent / "systems.py")


def set_order(hash_seed: int) -> list[str]:
    """The order a set of the headings iterates in under ``PYTHONHASHSEED=hash_seed``."""
    shown = subprocess.run(
        [sys.executable, "-c", "import sys; print(*set(sys.argv[1:]))", *HEADINGS],
        env={**os.environ, "PYTHONHASHSEED": str(hash_seed)},
        capture_output=True,
        text=True,
        check=True,
    )
    return shown.stdout.split()


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_every_leak_is_a_finding_with_its_site_and_count(
    auditors: Auditors, tmp_path: Path
) -> None:
    log = record_session(tmp_path / "leaky.beatlog", leaky_system(), cycles=20)

    report = audit(log, f"{SYSTEMS}:leaky_system", auditors=auditors)

    assert report.findings == tuple(Finding(call, site, 20) for call, site in leaks())
    assert [(run.hash_seed, run.ok, run.cycles) for run in report.runs] == [
        (1, True, 20),
        (2, True, 20),
    ]
    assert report.hash_seed_dependence is None
    assert (report.ok, report.problems) == (False, len(leaks()))
    assert report.summary() == f"{len(leaks())} findings"
    call, site = leaks()[0]
    assert report.lines()[0] == f"{call} at {site} (20 times)"
    assert pickle.loads(pickle.dumps(report)) == report  # it travels from suite workers


def test_a_py_trees_timer_on_the_wall_clock_is_named_in_py_trees_with_the_user_frame(
    auditors: Auditors,
    tmp_path: Path,
) -> None:
    log = record_session(tmp_path / "tree.beatlog", hand_ticked_tree(), cycles=20)
    via_line = next(
        number
        for number, line in enumerate(Path(SYSTEMS_FILE).read_text().splitlines(), 1)
        if "# leak via:" in line
    )

    report = audit(log, f"{SYSTEMS}:hand_ticked_tree", auditors=auditors)

    assert report.runs[0].ok
    assert report.hash_seed_dependence is None
    assert report.findings, "the timer's wall-clock reads went unseen"
    for finding in report.findings:
        assert finding.call in ("time.time", "time.monotonic")
        assert re.fullmatch(r".+/py_trees/timers\.py:\d+ in Timer\.\w+", finding.site), finding.site
        assert finding.via == f"{SYSTEMS_FILE}:{via_line} in HandTickedTree.step"
    assert report.lines()[0].endswith(f", from {SYSTEMS_FILE}:{via_line} in HandTickedTree.step")


def test_the_example_rover_is_deterministic(auditors: Auditors, tmp_path: Path) -> None:
    log = tmp_path / "rover.beatlog"
    recorded = record_lockstep(log, duration_s=3.0, seed=1)

    report = audit(log, "beatlog_examples.rover:system", auditors=auditors)

    assert report == AuditReport(findings=(), runs=report.runs, hash_seed_dependence=None)
    assert report.summary() == "no findings"
    assert report.lines() == []
    first, second = report.runs
    assert dataclasses.replace(first, hash_seed=2) == second  # the same replay under both seeds
    assert (first.ok, first.cycles, first.divergence_cycle, first.divergence_kind) == (
        True,
        recorded.cycles,
        None,
        None,
    )


def test_a_replay_that_passes_under_one_hash_seed_only_depends_on_it(
    auditors: Auditors, tmp_path: Path
) -> None:
    one, two = set_order(1), set_order(2)
    differs = next(cycle for cycle, (a, b) in enumerate(zip(one, two, strict=True)) if a != b)
    log = record_session(tmp_path / "unordered.beatlog", scripted_system(one))

    report = audit(log, f"{SYSTEMS}:unordered_system", auditors=auditors)

    assert report.hash_seed_dependence == (
        "the replay depends on the hash seed: PYTHONHASHSEED=1 passed, "
        f"PYTHONHASHSEED=2 diverged at cycle {differs} (state changes)"
    )
    assert report.runs[1].divergence_kind is DivergenceKind.STATE_CHANGES
    assert report.findings == ()
    assert report.problems == 1


def test_replays_that_diverge_alike_are_still_compared_cycle_by_cycle(
    auditors: Auditors, tmp_path: Path
) -> None:
    one, two = set_order(1), set_order(2)
    differs = next(cycle for cycle, (a, b) in enumerate(zip(one, two, strict=True)) if a != b)
    neither = [*one[:differs], "sideways", *one[differs + 1 :]]
    log = record_session(tmp_path / "unordered.beatlog", scripted_system(neither))

    report = audit(log, f"{SYSTEMS}:unordered_system", auditors=auditors)

    assert [run.describe() for run in report.runs] == [
        f"diverged at cycle {differs} (state changes)"
    ] * 2
    assert report.hash_seed_dependence == (
        "the replay depends on the hash seed: with PYTHONHASHSEED=1 and 2 the behavior "
        f"states and outputs differ from cycle {differs}"
    )


def test_a_log_whose_robot_state_fields_changed_is_audited_with_its_migration(
    auditors: Auditors,
    record_probe: RecordFn,
) -> None:
    log = record_probe(100)
    migration = StateMigration({"distance": "range"})

    report = audit(log, f"{SYSTEMS}:probe_system_ranged", migration=migration, auditors=auditors)

    assert report == AuditReport(findings=(), runs=report.runs, hash_seed_dependence=None)
    assert [run.describe() for run in report.runs] == ["passed", "passed"]
    with pytest.raises(BeatlogError, match="field 'distance' is gone"):
        audit(log, f"{SYSTEMS}:probe_system_ranged", auditors=auditors)


def test_draws_at_set_up_are_no_non_determinism(auditors: Auditors, tmp_path: Path) -> None:
    log = record_driver(tmp_path / "driver.beatlog")

    report = audit(log, f"{SYSTEMS}:driver_system", auditors=auditors)

    assert report == AuditReport(findings=(), runs=report.runs, hash_seed_dependence=None)
    assert [run.describe() for run in report.runs] == ["passed", "passed"]


def test_bad_input_is_a_beatlog_error_naming_the_file(auditors: Auditors, tmp_path: Path) -> None:
    with pytest.raises(BeatlogError, match=f"^{tmp_path / 'lost.beatlog'}: no such file"):
        audit(tmp_path / "lost.beatlog", f"{SYSTEMS}:leaky_system", auditors=auditors)


def test_a_replay_that_dies_is_a_loud_error(auditors: Auditors, tmp_path: Path) -> None:
    log = record_session(tmp_path / "leaky.beatlog", leaky_system())

    with pytest.raises(RuntimeError, match=r"PYTHONHASHSEED=1 crashed \(exit 70\)"):
        audit(log, f"{SYSTEMS}:exiting_system", auditors=auditors)


def test_ctrl_c_that_reaches_a_replay_first_is_ctrl_c_here(
    auditors: Auditors, tmp_path: Path
) -> None:
    log = record_session(tmp_path / "leaky.beatlog", leaky_system())

    with pytest.raises(KeyboardInterrupt):
        audit(log, f"{SYSTEMS}:interrupted_system", auditors=auditors)


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_replays_that_differ_by_an_unseeded_global_generator_say_so(
    auditors: Auditors, tmp_path: Path
) -> None:
    log = record_session(tmp_path / "gambler.beatlog", scripted_system(["left"] * 20))

    report = audit(log, f"{SYSTEMS}:gambler_system", auditors=auditors)

    assert report.hash_seed_dependence is not None
    assert re.fullmatch(
        r"the replay draws from an unseeded global random generator \(random\.choice\): "
        r"(with PYTHONHASHSEED=1 and 2 the behavior states and outputs differ from cycle \d+"
        r"|PYTHONHASHSEED=1 (passed|diverged at cycle \d+ \([a-z ]+\)), "
        r"PYTHONHASHSEED=2 (passed|diverged at cycle \d+ \([a-z ]+\)))",  # as the draws fall
        report.hash_seed_dependence,
    ), report.hash_seed_dependence
    assert "hash seed" not in report.hash_seed_dependence.split(":")[0]
    assert [finding.call for finding in report.findings] == ["random.choice"]


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_the_audit_interpreters_are_kept_for_the_next_audit_and_stopped_at_the_end(
    record_probe: RecordFn, meeting: Path
) -> None:
    log = record_probe(30)

    with Auditors() as auditors:
        reports = [audit(log, "tests.conftest:alone_system", auditors=auditors) for _ in range(3)]

    assert [report.ok for report in reports] == [True, True, True]
    signed = sorted(int(sign.name) for sign in meeting.iterdir())
    assert len(signed) == 2  # one interpreter per hash seed, not two per audit
    assert os.getpid() not in signed
    for pid in signed:
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


def test_an_audit_without_auditors_stops_its_own_interpreters(
    record_probe: RecordFn, meeting: Path
) -> None:
    log = record_probe(30)

    report = audit(log, "tests.conftest:alone_system")

    assert report == AuditReport(findings=(), runs=report.runs, hash_seed_dependence=None)
    signed = [int(sign.name) for sign in meeting.iterdir()]
    assert len(signed) == 2
    for pid in signed:
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


def test_replays_that_differ_by_an_unseeded_generator_of_the_systems_own_name_it(
    auditors: Auditors, tmp_path: Path
) -> None:
    made, drawn = drifter_sites()
    log = record_session(tmp_path / "drifter.beatlog", scripted_system(["left"] * 20))

    report = audit(log, f"{SYSTEMS}:drifter_system", auditors=auditors)

    generator = f"numpy.random.Generator made at {made}"
    assert report.hash_seed_dependence is not None
    assert report.hash_seed_dependence.startswith(
        f"the replay draws from an unseeded random generator ({generator}): "
    ), report.hash_seed_dependence
    assert [(finding.call, finding.site) for finding in report.findings] == [
        (f"unseeded {generator}", drawn)
    ]
