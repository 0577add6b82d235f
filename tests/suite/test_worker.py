"""Suite workers: processes that import only what replay needs and replay spec after spec."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from beatlog.baseline.policy import SpecOptions
from beatlog.suite.runner import Verdict
from beatlog.suite.spec import DtcSpec
from beatlog.suite.worker import Worker, WorkerLostError
from tests.conftest import RecordFn

ALONE = "tests.conftest:alone_system"

NOT_FOR_REPLAY = ("beatlog.cli", "beatlog.audit.replays", "rich", "numpy", "multiprocessing")
"""What a worker that replays without an audit must not have imported."""


def spec(folder: Path, name: str, log: Path, system: str) -> DtcSpec:
    return DtcSpec(folder / f"{name}.dtc.toml", name, "A test.", (), log, system)


def imported(meeting: Path) -> dict[int, list[str]]:
    """The modules each process had imported when it built a meeting system, by pid."""
    return {int(sign.name): sign.read_text().splitlines() for sign in meeting.iterdir()}


def test_a_worker_imports_only_what_replay_needs(
    tmp_path: Path, record_probe: RecordFn, meeting: Path
) -> None:
    with Worker() as worker:
        worker.wait_ready()
        outcome = worker.run(spec(tmp_path, "alone", record_probe(30), ALONE), SpecOptions())

    assert outcome.verdict is Verdict.PASSED
    [(pid, modules)] = imported(meeting).items()
    assert pid != os.getpid()
    assert "beatlog.replay.judge" in modules
    for name in NOT_FOR_REPLAY:
        assert [m for m in modules if m == name or m.startswith(f"{name}.")] == [], name


def test_a_worker_gathers_the_timelines_of_what_it_judged(
    tmp_path: Path, record_probe: RecordFn, meeting: Path
) -> None:
    with Worker() as worker:
        outcome = worker.run(
            spec(tmp_path, "alone", record_probe(30), ALONE), SpecOptions(timelines=True)
        )

    (timeline,) = outcome.timelines
    assert (timeline.cycles, timeline.replayed, timeline.divergence) == (30, True, None)
    assert [lane.behavior for lane in timeline.lanes] == ["arbiter", "near", "dice"]
    assert [lane.actual for lane in timeline.lanes] == [lane.expected for lane in timeline.lanes]


def test_a_worker_replays_spec_after_spec_in_one_process(
    tmp_path: Path, record_probe: RecordFn, meeting: Path
) -> None:
    log = record_probe(30)

    with Worker() as worker:
        outcomes = [
            worker.run(spec(tmp_path, name, log, ALONE), SpecOptions()) for name in ("a", "b")
        ]

    assert [o.verdict for o in outcomes] == [Verdict.PASSED, Verdict.PASSED]
    assert [o.spec.name for o in outcomes] == ["a", "b"]
    assert len(imported(meeting)) == 1  # start-up paid once


def test_a_worker_that_dies_is_reported_not_waited_for(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    dying = spec(tmp_path, "dying", record_probe(30), "tests.conftest:dying_system")

    with Worker() as worker, pytest.raises(WorkerLostError, match=r"\(exit 3\)"):
        worker.run(dying, SpecOptions())


def test_a_worker_interrupted_by_ctrl_c_interrupts_its_runner(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    interrupted = spec(tmp_path, "stopped", record_probe(30), "tests.conftest:interrupted_system")

    with Worker() as worker, pytest.raises(KeyboardInterrupt):
        worker.run(interrupted, SpecOptions())
