"""What a DTC takes to a Dask worker that does not share this machine's files: its
baseline, its local log and its project's ``pyproject.toml``, unpacked in the worker's
folder, messages naming them as here, and one line for a worker without the system."""

from __future__ import annotations

import dataclasses
import pickle
import shutil
from pathlib import Path

import pytest

from beatlog.baseline.policy import SpecOptions, UpdateMode
from beatlog.suite.maintenance import approve, update_baselines
from beatlog.suite.parallel import run_suite
from beatlog.suite.runner import Verdict, run_spec
from beatlog.suite.selection import fleet_specs
from beatlog.suite.shipping import (
    absolute,
    as_given,
    as_here,
    missing_system,
    packed,
    received,
    replayed,
    shipped,
    unpacked,
)
from beatlog.suite.spec import load_spec
from tests.conftest import RecordFn
from tests.specs import CHANGED, write_spec


@pytest.fixture
def checkout(tmp_path: Path, record_probe: RecordFn) -> Path:
    """A project whose spec replays a changed system against its approved baseline."""
    (tmp_path / "checkout" / "logs").mkdir(parents=True)
    (tmp_path / "checkout" / "pyproject.toml").write_text("[project]\nname = 'robot'\n")
    log = record_probe(120, name="checkout/logs/walk.beatlog")
    spec = write_spec(tmp_path / "checkout" / "dtc", "walk", log, CHANGED)
    update_baselines(run_suite([load_spec(spec)], update=UpdateMode.NEW), UpdateMode.NEW)
    approve([spec])
    return tmp_path / "checkout"


def test_a_dtc_shipped_elsewhere_is_judged_against_its_baseline_as_here(
    checkout: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    shipped = packed(load_spec(checkout / "dtc" / "walk.dtc.toml"))
    shutil.rmtree(checkout)
    (tmp_path / "worker").mkdir()
    monkeypatch.chdir(tmp_path / "worker")

    spec = unpacked(shipped, tmp_path / "worker")
    outcome = run_spec(spec)

    assert sorted(shipped.files) == [
        "dtc/walk.dtc.expected",
        "logs/walk.beatlog",
        "pyproject.toml",
    ]
    assert outcome.verdict is Verdict.PASSED, outcome.error
    assert outcome.baseline == tmp_path / "worker" / "dtc" / "walk.dtc.expected"


def test_a_message_names_the_shipped_files_as_they_are_here(checkout: Path, tmp_path: Path) -> None:
    shipped = packed(load_spec(checkout / "dtc" / "walk.dtc.toml"))
    worker = tmp_path / "worker"

    message = f"{worker / 'logs' / 'walk.beatlog'}: cut off"

    assert as_here(message, shipped, worker) == f"{checkout / 'logs' / 'walk.beatlog'}: cut off"


def test_a_worker_without_the_systems_package_is_one_line(
    checkout: Path,
) -> None:
    spec = load_spec(write_spec(checkout / "dtc", "lost", Path("x.beatlog"), "robotcode:system"))

    assert missing_system(spec, "host-3") == (
        "the worker host-3 has no package 'robotcode' (robotcode:system): "
        "install the system's package on the cluster's workers"
    )
    assert missing_system(load_spec(checkout / "dtc" / "walk.dtc.toml"), "host-3") is None


def test_a_fleet_log_ships_alone(checkout: Path) -> None:
    [spec] = fleet_specs(f"{checkout}/logs/*.beatlog", system=CHANGED)

    shipped = packed(spec)

    assert list(shipped.files) == ["logs/walk.beatlog"]


def test_a_fleet_log_behind_a_url_goes_as_it_is_and_a_local_one_with_absolute_paths(
    checkout: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(checkout)
    [local] = fleet_specs("logs/*.beatlog", system=CHANGED)
    url = "s3://fleet/logs/walk.beatlog"
    behind_url = dataclasses.replace(local, log=Path("walk.beatlog"), source=url, log_url=url)

    assert absolute(behind_url) is behind_url  # it reads no file here
    sent = absolute(local)
    assert (sent.path, sent.log) == (checkout / "logs/walk.beatlog",) * 2


def test_a_tasks_outcomes_come_back_without_their_specs(checkout: Path) -> None:
    given = load_spec(checkout / "dtc" / "walk.dtc.toml")

    sent = replayed(shipped([absolute(given)], []), options=SpecOptions())

    with pytest.raises(pickle.UnpicklingError):  # the client's own specs complete them
        pickle.loads(sent)
    [outcome] = received(sent, [given])
    assert outcome.spec is given
    assert outcome.verdict is Verdict.PASSED, outcome.error


def test_a_task_travels_as_bytes_its_worker_alone_unpickles(checkout: Path) -> None:
    given = load_spec(checkout / "dtc" / "walk.dtc.toml")

    task = shipped([packed(absolute(given))], [])

    assert isinstance(task, bytes)  # what Dask's scheduler passes on unopened
    [outcome] = received(replayed(task, options=SpecOptions()), [given])
    assert outcome.verdict is Verdict.PASSED, outcome.error


def test_a_fleet_logs_outcome_is_told_as_it_came_but_for_its_retries(checkout: Path) -> None:
    [given] = fleet_specs(f"{checkout}/logs/*.beatlog", system=CHANGED)
    [outcome] = received(replayed(shipped([absolute(given)], []), options=SpecOptions()), [given])

    assert as_given(outcome, 0) is outcome  # nothing of it named otherwise here: no copy
    assert as_given(outcome, 2).retries == 2
    assert as_given(outcome, 2).result == outcome.result
