"""Suites on a Dask cluster (``beatlog test --dask``): a real ``LocalCluster`` of worker
processes gives the verdicts, reports and exit codes of a local run, downloads the logs
behind URLs (fleet and spec logs) on the workers alone, retries a DTC whose worker died,
and cancels on Ctrl-C."""

from __future__ import annotations

import logging
import os
import re
import socket
import subprocess
import sys
import threading
import time
import tracemalloc
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import dask
import pytest
from distributed import (
    Client,
    Future,
    LocalCluster,
    Scheduler,
    SchedulerPlugin,
    get_task_stream,
)

from beatlog.baseline.policy import SpecOptions
from beatlog.cli.main import main
from beatlog.suite import cluster as cluster_module
from beatlog.suite.cluster import (
    CLUSTER_SETTINGS,
    NO_WORKERS_S,
    THREADS_ASKED_EVERY_S,
    DaskExecutor,
    WorkerDeaths,
)
from beatlog.suite.discovery import discover_specs
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.selection import fleet_specs
from tests.commands import Run, assert_error, assert_error_matching, closing_counts
from tests.conftest import RecordFn
from tests.served import LogServer
from tests.specs import CHANGED, FIRST_CHANGED_CYCLE, PROBE, write_spec
from tests.text import table_row, whole_lines
from tests.workers import DyingWhenFetched

DYING = "tests.conftest:dying_system"


@pytest.fixture(scope="module")
def cluster() -> Iterator[str]:
    """A cluster of two worker processes, shared by this module's tests; a DTC whose
    worker dies is run again once, then is an error."""
    with local_cluster(2, allowed_failures=1) as local:
        yield local.scheduler_address


def local_cluster(workers: int, *, allowed_failures: int = 3) -> LocalCluster:
    """A cluster of ``workers`` worker processes of one thread each, on no fixed port (runs
    side by side never clash), quiet; a task whose workers die ``allowed_failures`` + 1
    times is an error."""
    with dask.config.set(CLUSTER_SETTINGS):  # as the guide advises for a cluster's own
        return LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.CRITICAL,
            scheduler_kwargs={"allowed_failures": allowed_failures},
        )


def test_a_local_clusters_processes_check_their_event_loops_once_a_second(cluster: str) -> None:
    def every_ms(dask_scheduler: Any = None, dask_worker: Any = None) -> list[float]:
        callbacks = (dask_scheduler or dask_worker).periodic_callbacks
        return [callbacks["tick"].callback_time, callbacks["monitor"].callback_time]

    with Client(cluster, set_as_default=False) as client:
        every = [client.run_on_scheduler(every_ms), *client.run(every_ms).values()]

    assert every == [[1000, 5000]] * 3  # Dask's 20 and 500 ms cost idle workers 2/3 of their CPU


@pytest.fixture
def beatlog(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> Callable[..., Run]:
    """``beatlog ARGS`` in process, as given (no ``-j``: it excludes ``--dask``), on a
    console wide enough for long temporary paths."""
    monkeypatch.setenv("COLUMNS", "200")

    def run(*args: str | Path) -> Run:
        code = main([str(arg) for arg in args])
        captured = capsys.readouterr()
        return Run(code, captured.out, captured.err)

    return run


@pytest.fixture
def suite(tmp_path: Path, record_probe: RecordFn) -> Path:
    """Three specs of two logs: two pass, one replays a changed system and fails."""
    first, second = (
        record_probe(300, name="first.beatlog"),
        record_probe(120, name="second.beatlog"),
    )
    folder = tmp_path / "suite"
    write_spec(folder, "first", first)
    write_spec(folder, "second", second)
    write_spec(folder, "changed", first, CHANGED)
    return folder


def junit_cases(path: Path) -> list[tuple[str | None, list[str]]]:
    """Each testcase of a JUnit report: its name and the tags of what it holds."""
    cases = ET.parse(path).getroot().iter("testcase")
    return [(case.get("name"), [child.tag for child in case]) for case in cases]


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_a_cluster_gives_the_verdicts_reports_and_exit_code_of_a_local_run(
    beatlog: Callable[..., Run], cluster: str, suite: Path, tmp_path: Path
) -> None:
    local = beatlog("test", suite, "-j", "1", "--junit-xml", tmp_path / "local.xml")
    remote = beatlog("test", suite, "--dask", cluster, "--junit-xml", tmp_path / "dask.xml")

    assert remote.code == local.code == 1
    counts = [closing_counts(run.out) for run in (local, remote)]
    assert counts == ["2 passed, 1 failed", "2 passed, 1 failed"]
    rerun = f"reproduce: beatlog test {suite / 'changed.dtc.toml'}"
    assert rerun in local.out
    assert rerun in remote.out
    assert (
        f"first divergence: cycle {FIRST_CHANGED_CYCLE}, t = 0.660 s, state changes"
        in whole_lines(remote.out)
    )
    assert junit_cases(tmp_path / "dask.xml") == junit_cases(tmp_path / "local.xml")
    assert junit_cases(tmp_path / "dask.xml") == [
        ("changed", ["properties", "failure"]),
        ("first", ["properties"]),
        ("second", ["properties"]),
    ]


def test_a_suite_given_by_a_relative_path_is_reported_by_it_as_a_local_run_is(
    beatlog: Callable[..., Run],
    cluster: str,
    suite: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    (suite / "broken.beatlog").write_bytes(b"not a session log")
    write_spec(suite, "broken", suite / "broken.beatlog")
    monkeypatch.chdir(tmp_path)

    local = beatlog("test", "suite", "-j", "1")
    remote = beatlog("test", "suite", "--dask", cluster)

    for run in (local, remote):
        assert run.code == 2
        assert str(tmp_path) not in run.out + run.err
        failed = run.out.splitlines()[1]
        assert re.fullmatch(
            r"FAIL suite/\.\./first\.beatlog  22 cycles, 0\.7 s robot time in [^;]+; log complete",
            failed,
        ), failed
        assert run.err == (
            "beatlog: error: broken (suite/broken.dtc.toml): "
            "suite/broken.beatlog: not a session log (not an MCAP file)\n"
        )


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_local_1_starts_a_cluster_of_one_worker_process_for_the_run(
    beatlog: Callable[..., Run], suite: Path
) -> None:
    run = beatlog("test", suite, "--dask", "local:1", "-k", "second")

    assert run.code == 0, run.err
    assert closing_counts(run.out) == "1 passed, 0 failed"


@pytest.mark.slow
def test_local_n_starts_a_cluster_of_n_worker_processes_for_the_run(
    beatlog: Callable[..., Run], suite: Path
) -> None:
    run = beatlog("test", suite, "--dask", "local:2", "-k", "not changed")

    assert run.code == 0, run.err
    assert closing_counts(run.out) == "2 passed, 0 failed"


def test_fleet_logs_behind_an_http_url_are_downloaded_once_each_by_the_workers(
    beatlog: Callable[..., Run], cluster: str, served: LogServer
) -> None:
    url = served.url
    run = beatlog("test", "--logs", f"{url}/*.beatlog", "--system", CHANGED, "--dask", cluster)

    assert run.code == 1, run.err
    assert closing_counts(run.out) == "0 passed, 2 failed"
    assert f"reproduce: beatlog test --logs {url}/dock.beatlog --system {CHANGED}" in whole_lines(
        run.out
    )
    assert [served.downloads(name) for name in ("dock.beatlog", "yard.beatlog")] == [1, 1]


def test_a_spec_whose_log_is_a_url_gets_the_verdict_of_a_local_run(
    beatlog: Callable[..., Run], cluster: str, served: LogServer, tmp_path: Path
) -> None:
    folder = tmp_path / "suite"
    write_spec(folder, "dock", f"{served.url}/dock.beatlog")
    write_spec(folder, "yard", f"{served.url}/yard.beatlog", CHANGED)

    local = beatlog("test", folder, "-j", "1", "--junit-xml", tmp_path / "local.xml")
    local_downloads = served.downloads("dock.beatlog")
    remote = beatlog("test", folder, "--dask", cluster, "--junit-xml", tmp_path / "dask.xml")

    assert remote.code == local.code == 1, remote.err
    assert [closing_counts(run.out) for run in (local, remote)] == ["1 passed, 1 failed"] * 2
    assert junit_cases(tmp_path / "dask.xml") == junit_cases(tmp_path / "local.xml")
    assert f"reproduce: beatlog test {folder / 'yard.dtc.toml'}" in whole_lines(remote.out)
    assert (local_downloads, served.downloads("dock.beatlog")) == (1, 2)


def test_a_spec_whose_log_is_not_found_is_an_error_of_its_dtc(
    beatlog: Callable[..., Run], cluster: str, served: LogServer, tmp_path: Path
) -> None:
    spec = write_spec(tmp_path / "suite", "lost", f"{served.url}/lost.beatlog")

    run = beatlog("test", spec, "--dask", cluster)

    assert run.code == 2
    assert run.err == f"beatlog: error: lost ({spec}): {served.url}/lost.beatlog: no such log\n"
    assert closing_counts(run.out) == "0 passed, 0 failed, 1 error"


def removed(keys: list[str], *, expected: bool = False) -> tuple[float, object]:
    """The scheduler's event of a worker removed while it ran ``keys``."""
    message = {"action": "remove-worker", "processing-tasks": keys, "expected": expected}
    return (0.0, message)


def test_retries_are_counted_from_the_workers_removed_unexpectedly_while_running_a_dtc() -> None:
    deaths = WorkerDeaths()
    for event in (
        removed(["dtc-a", "dtc-b"]),
        (0.0, {"action": "add-worker", "worker": "tcp://127.0.0.1:1"}),
        removed(["dtc-a"]),
        removed(["dtc-c"], expected=True),  # retired on purpose: not the DTC's doing
        (0.0, "a message of another kind"),
    ):
        deaths.seen(event)

    assert [deaths[key] for key in ("dtc-a", "dtc-b", "dtc-c", "dtc-d")] == [2, 1, 0, 0]


def write_dying_once(folder: Path, marker: Path, *, first: bool = True) -> str:
    """A system module beside the specs whose factory ends its process the first time
    (``marker`` then exists) and builds the probe system after; or, not ``first``, builds
    it the first time and ends its process every time after."""
    folder.mkdir(parents=True, exist_ok=True)
    name = "dying_once" if first else "built_once"
    (folder / f"{name}.py").write_text(
        "import os\n"
        "from pathlib import Path\n"
        "from tests.conftest import probe_system\n\n\n"
        "def system():\n"
        f"    marker = Path({str(marker)!r})\n"
        "    seen = marker.exists()\n"
        "    marker.touch()\n"
        f"    if seen is {not first}:\n"
        "        os._exit(3)\n"
        "    return probe_system()\n",
        encoding="utf-8",
    )
    return f"{name}:system"


def test_a_dtc_whose_worker_dies_is_retried_and_the_report_says_so(
    beatlog: Callable[..., Run], cluster: str, tmp_path: Path, record_probe: RecordFn
) -> None:
    folder = tmp_path / "suite"
    marker = tmp_path / "died"
    write_spec(folder, "unlucky", record_probe(120), write_dying_once(folder, marker))

    page = tmp_path / "report.html"
    run = beatlog(
        "test", folder, "--dask", cluster, "--junit-xml", tmp_path / "dtc.xml", "--html", page
    )

    assert marker.exists()
    assert run.code == 0, run.err
    assert "retried unlucky: the worker replaying it died (1 time)" in whole_lines(run.out)
    assert table_row(run.out, "unlucky")[:4] == ["unlucky", "passed (retried 1×)", "120", "3.6 s"]
    assert junit_cases(tmp_path / "dtc.xml") == [("unlucky", ["properties", "flakyError"])]
    rows = re.findall(
        r'<tr class="(\w+)"><td><a href="#dtc-\d+">([^<]*)</a></td>'
        r'<td><span class="verdict">([^<]*)</span></td><td>(\d+)</td>',
        page.read_text(),
    )
    assert rows == [("passed", "unlucky", "passed (retried 1×)", "120")]


def assert_workers_died(run: Run, spec: Path, workers: str) -> None:
    """The run ends in exit code 2 and one line: the DTC of ``spec`` is an error, its
    ``workers`` (``2 workers``) having died while replaying it."""
    name = spec.name.removesuffix(".dtc.toml")
    assert run.code == 2
    assert run.err == (
        f"beatlog: error: {name} ({spec}): {workers} died while replaying it "
        "(a crash, or a machine lost)\n"
    )


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_a_dtc_whose_workers_keep_dying_is_an_error_never_lost(
    beatlog: Callable[..., Run], cluster: str, tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(120)
    write_spec(tmp_path / "suite", "fine", log)
    write_spec(tmp_path / "suite", "doomed", log, DYING)

    run = beatlog("test", tmp_path / "suite", "--dask", cluster)

    assert_workers_died(run, tmp_path / "suite" / "doomed.dtc.toml", "2 workers")
    assert closing_counts(run.out) == "1 passed, 0 failed, 1 error"


def write_waiting(folder: Path, release: Path, name: str = "waiting") -> str:
    """A system module ``name`` beside the specs whose factory waits until ``release``
    exists (a minute at most); a worker keeps the module it imported first by that name."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.py").write_text(
        "import time\n"
        "from pathlib import Path\n"
        "from tests.conftest import probe_system\n\n\n"
        "def system():\n"
        "    deadline = time.monotonic() + 60\n"
        f"    while not Path({str(release)!r}).exists() and time.monotonic() < deadline:\n"
        "        time.sleep(0.01)\n"
        "    return probe_system()\n",
        encoding="utf-8",
    )
    return f"{name}:system"


def dtc_tasks(dask_scheduler: object) -> int:
    """On the scheduler: how many DTC tasks it still holds."""
    return sum(str(key).startswith("dtc-") for key in dask_scheduler.tasks)  # type: ignore[attr-defined]


def test_ctrl_c_cancels_the_tasks_not_complete(
    cluster: str, tmp_path: Path, record_probe: RecordFn
) -> None:
    log, release = record_probe(60), tmp_path / "release"
    waiting = write_waiting(tmp_path / "suite", release)
    write_spec(tmp_path / "suite", "a-quick", log)
    for name in ("b-waits", "c-waits", "d-waits"):
        write_spec(tmp_path / "suite", name, log, waiting)
    seen: list[SpecOutcome] = []

    def press_ctrl_c(outcome: SpecOutcome) -> bool:
        seen.append(outcome)
        raise KeyboardInterrupt

    with Client(cluster, set_as_default=False) as watcher:
        try:
            with DaskExecutor(cluster) as executor, pytest.raises(KeyboardInterrupt):
                executor(discover_specs([tmp_path / "suite"]), SpecOptions(), press_ctrl_c)
            assert [outcome.spec.name for outcome in seen] == ["a-quick"]
            assert watcher.run_on_scheduler(dtc_tasks) == 0
        finally:
            release.touch()


def running_dtc_tasks(dask_scheduler: Scheduler) -> list[str]:
    """On the scheduler: the keys of the DTC tasks its workers are running."""
    return [
        str(key)
        for key, task in dask_scheduler.tasks.items()
        if str(key).startswith("dtc-") and task.state == "processing"
    ]


def test_a_dtc_whose_task_is_cancelled_on_the_cluster_is_never_a_pass(
    beatlog: Callable[..., Run], cluster: str, tmp_path: Path, record_probe: RecordFn
) -> None:
    log, release = record_probe(60), tmp_path / "release"
    waiting = write_waiting(tmp_path / "suite", release, "waiting_to_be_cancelled")
    write_spec(tmp_path / "suite", "waits", log, waiting)

    def cancel_from_another_client() -> None:
        with Client(cluster, set_as_default=False) as other:
            deadline = time.monotonic() + 60
            while not (keys := other.run_on_scheduler(running_dtc_tasks)):
                assert time.monotonic() < deadline
                time.sleep(0.05)
            other.cancel([Future(key, other) for key in keys], force=True)

    canceller = threading.Thread(target=cancel_from_another_client)
    canceller.start()
    try:
        run = beatlog("test", tmp_path / "suite", "--dask", cluster)
    finally:
        canceller.join()
        release.touch()

    assert run.code == 2, run
    assert run.err == (
        f"beatlog: error: --dask {cluster}: their tasks were cancelled on the cluster (by "
        "another client, or a scheduler that restarted): 1 of 1 DTCs not run\n"
    )


@pytest.mark.slow
def test_a_suite_runs_on_workers_that_do_not_share_its_folder(
    tmp_path: Path, record_probe: RecordFn, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "code").mkdir()  # installed on the workers alone
    (tmp_path / "code" / "removing.py").write_text(
        "import shutil\n"
        "from tests.conftest import probe_system\n\n\n"
        "def system():\n"
        f"    shutil.rmtree({str(tmp_path / 'checkout')!r})  # before the replay reads a file\n"
        "    return probe_system()\n",
        encoding="utf-8",
    )
    (tmp_path / "checkout").mkdir()
    log = record_probe(60, name="checkout/walk.beatlog")
    write_spec(tmp_path / "checkout", "a-quick", log)
    write_spec(tmp_path / "checkout", "b-removes", log, "removing:system")
    specs = discover_specs([tmp_path / "checkout"])
    outcomes: list[SpecOutcome] = []

    def kept(outcome: SpecOutcome) -> bool:
        outcomes.append(outcome)
        return False

    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    monkeypatch.syspath_prepend(tmp_path / "code")  # workers start with this sys.path
    with local_cluster(1) as elsewhere, DaskExecutor(elsewhere.scheduler_address) as executor:
        executor(specs, SpecOptions(), kept)

    assert not (tmp_path / "checkout").exists()
    assert sorted((o.spec.name, o.verdict.value, o.error) for o in outcomes) == [
        ("a-quick", "passed", None),
        ("b-removes", "passed", None),
    ]


@pytest.fixture
def no_workers() -> Iterator[str]:
    """The address of a scheduler that has no workers."""
    with local_cluster(0) as empty:
        yield empty.scheduler_address


def test_a_cluster_that_never_has_a_worker_ends_the_run_in_one_line(
    beatlog: Callable[..., Run],
    no_workers: str,
    suite: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    assert NO_WORKERS_S == 60
    monkeypatch.setattr(cluster_module, "NO_WORKERS_S", 0.5)

    run = beatlog("test", suite, "--dask", no_workers)

    assert_error(
        run,
        f"--dask {no_workers}: the cluster has had no workers for 0.5 s "
        "(all lost, none restarted): 3 of 3 DTCs not run",
    )


@pytest.mark.slow  # a worker process of its own: 2 s or more
def test_a_cluster_whose_workers_are_all_killed_ends_the_run_after_the_outcomes_so_far(
    beatlog: Callable[..., Run],
    no_workers: str,
    tmp_path: Path,
    record_probe: RecordFn,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(cluster_module, "NO_WORKERS_S", 0.5)
    write_spec(tmp_path / "suite", "a-quick", record_probe(120))  # longer: it runs first
    write_spec(tmp_path / "suite", "b-kills", record_probe(60, name="short.beatlog"), DYING)
    worker = subprocess.Popen(  # no nanny: killed, it is not restarted
        [sys.executable, "-m", "distributed.cli.dask_worker", no_workers, "--no-nanny"],
        env={**os.environ, "PYTHONPATH": os.pathsep.join([str(Path.cwd()), *sys.path])},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        with Client(no_workers, set_as_default=False) as watcher:
            watcher.wait_for_workers(1, timeout=60)
        run = beatlog("test", tmp_path / "suite", "--dask", no_workers)
    finally:
        worker.kill()
        worker.wait()

    assert run.code == 2, run
    assert table_row(run.out, "a-quick")[1:2] == ["passed"], run
    assert "b-kills" not in run.out
    assert run.err == (
        f"beatlog: error: --dask {no_workers}: the cluster has had no workers for 0.5 s "
        "(all lost, none restarted): 1 of 2 DTCs not run\n"
    )


def unused_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port


def assert_unreachable(run: Run, address: str) -> None:
    """One line saying the cluster at ``address`` cannot be reached, in either of the ways a
    half-second connect ends: a connection that timed out, or a peer that never answered."""
    assert (run.code, run.out) == (2, "")
    at = re.escape(address)
    assert re.fullmatch(
        rf"beatlog: error: --dask {at}: cannot reach the cluster: "
        rf"(Timed out trying to connect to {at} after 0\.5 s"
        r"|no Dask scheduler answered there within 0\.5 s)\n",
        run.err,
    ), run.err


def test_a_cluster_that_cannot_be_reached_is_one_line_and_exit_2(
    beatlog: Callable[..., Run], suite: Path
) -> None:
    address = f"tcp://127.0.0.1:{unused_port()}"

    with dask.config.set({"distributed.comm.timeouts.connect": "0.5s"}):
        run = beatlog("test", suite, "--dask", address)

    assert_unreachable(run, address)


def test_a_server_that_never_answers_the_handshake_is_one_line_and_exit_2(
    beatlog: Callable[..., Run], suite: Path
) -> None:
    with socket.socket() as silent:  # it takes connections, and says nothing
        silent.bind(("127.0.0.1", 0))
        silent.listen()
        address = f"tcp://127.0.0.1:{silent.getsockname()[1]}"
        with dask.config.set({"distributed.comm.timeouts.connect": "0.5s"}):
            run = beatlog("test", suite, "--dask", address)

    assert_unreachable(run, address)


def test_a_server_that_is_not_a_scheduler_is_one_line_and_exit_2(
    beatlog: Callable[..., Run], suite: Path
) -> None:
    with socket.socket() as web:  # a dashboard's port, say: it answers in HTTP
        web.bind(("127.0.0.1", 0))
        web.listen()
        address = f"tcp://127.0.0.1:{web.getsockname()[1]}"
        answer = threading.Thread(target=answer_in_http, args=(web,), daemon=True)
        answer.start()
        with dask.config.set({"distributed.comm.timeouts.connect": "5s"}):
            run = beatlog("test", suite, "--dask", address)

    assert_error_matching(  # the error a Dask client fails with on what it cannot decode
        run,
        re.escape(f"--dask {address}: cannot reach the cluster: ")
        + r"what answers there is not a Dask scheduler \(\w+\)",
    )


def answer_in_http(server: socket.socket) -> None:
    """Answer the first connection as a web server answers what it cannot parse."""
    connection, _ = server.accept()
    with connection:
        connection.sendall(b"HTTP/1.0 400 Bad Request\r\nContent-Length: 0\r\n\r\n")


@pytest.mark.parametrize("address", ["local:0", "local:two", "local2"])
def test_a_local_cluster_of_no_workers_is_one_line_and_exit_2(
    beatlog: Callable[..., Run], suite: Path, address: str
) -> None:
    run = beatlog("test", suite, "--dask", address)

    assert_error(
        run, f"--dask {address}: expected local, or local:N with N worker processes from 1"
    )


def test_dask_and_jobs_exclude_each_other(beatlog: Callable[..., Run], suite: Path) -> None:
    run = beatlog("test", suite, "--dask", "local:2", "-j", "2")

    assert_error(
        run, "argument -j/--jobs: not allowed with argument --dask (see 'beatlog test --help')"
    )


def test_break_points_and_dask_exclude_each_other(beatlog: Callable[..., Run], suite: Path) -> None:
    run = beatlog("test", suite, "--dask", "local:2", "--break-on-divergence")

    assert_error(run, "break points stop in this process: leave out --dask")


def test_variants_run_on_the_cluster_as_they_run_here(
    beatlog: Callable[..., Run], cluster: str, tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(100, start_time_ns=1_700_000_000_000_000_000)  # its variants keyed
    folder = tmp_path / "suite"
    variants = {"count": 3, "noise": {"distance": 0.05}}
    write_spec(folder, "dock", log, "tests.systems:fussy_system", variants=variants)

    local = beatlog("test", folder, "-j", "1", "--junit-xml", tmp_path / "local.xml")
    written = sorted(folder.glob("*.variant-*.dtc.toml"))
    for path in written:
        path.unlink()
    remote = beatlog("test", folder, "--dask", cluster, "--junit-xml", tmp_path / "dask.xml")

    assert remote.code == local.code == 1
    assert closing_counts(remote.out) == closing_counts(local.out)
    assert junit_cases(tmp_path / "dask.xml") == junit_cases(tmp_path / "local.xml")
    assert sorted(folder.glob("*.variant-*.dtc.toml")) == written


@pytest.mark.slow
def test_local_logs_are_read_for_the_cluster_only_as_their_dtcs_are_submitted(
    cluster: str, tmp_path: Path
) -> None:
    (tmp_path / "fleet").mkdir()
    first = tmp_path / "fleet" / "log-000.beatlog"
    first.write_bytes(os.urandom(1 << 20))
    for index in range(1, 200):  # links: 200 MiB of logs to ship, 1 MiB on disk
        os.link(first, tmp_path / "fleet" / f"log-{index:03}.beatlog")
    specs = fleet_specs(f"{tmp_path}/fleet/*.beatlog", system=CHANGED)
    outcomes: list[SpecOutcome] = []

    def judged(outcome: SpecOutcome) -> bool:
        outcomes.append(outcome)
        return False

    tracemalloc.start()
    try:
        with DaskExecutor(cluster) as executor:
            executor(specs, SpecOptions(), judged)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()

    assert len(outcomes) == 200
    assert all(outcome.verdict is Verdict.ERROR for outcome in outcomes)
    assert "no such" not in (outcomes[0].error or "")  # the worker read the log shipped
    assert peak < 40 << 20, f"{peak >> 20} MiB held to ship 200 MiB of logs"


@pytest.fixture
def many(tmp_path: Path, record_probe: RecordFn) -> Path:
    """Twenty-four DTCs of one short log, the fifth replaying a changed system and the
    tenth a system that cannot be built: on two threads, tasks of three DTCs."""
    log = record_probe(40)
    folder = tmp_path / "many"
    for index in range(24):
        system = {4: CHANGED, 9: "tests.conftest:broken_probe"}.get(index, PROBE)
        write_spec(folder, f"dtc-{index:02}", log, system)
    return folder


def test_each_dtc_of_a_task_of_several_gets_its_own_verdict(
    beatlog: Callable[..., Run], cluster: str, many: Path, tmp_path: Path
) -> None:
    local = beatlog("test", many, "-j", "1", "--junit-xml", tmp_path / "local.xml")
    with (
        Client(cluster, set_as_default=False) as watcher,
        get_task_stream(client=watcher) as stream,
    ):
        remote = beatlog("test", many, "--dask", cluster, "--junit-xml", tmp_path / "dask.xml")

    assert remote.code == local.code == 2
    assert closing_counts(remote.out) == closing_counts(local.out) == "22 passed, 1 failed, 1 error"
    assert junit_cases(tmp_path / "dask.xml") == junit_cases(tmp_path / "local.xml")
    assert "the arena map is missing" in remote.err
    ran = [str(task["key"]) for task in stream.data if str(task["key"]).startswith("dtc-")]
    assert len(ran) < 24  # several DTCs a task


class MostHeld(SchedulerPlugin):
    """On a scheduler: the most DTC tasks one worker has held at once, run or queued, and
    the most all its workers have."""

    name = "most-held"

    def __init__(self) -> None:
        self.most = (0, 0)
        self.workers: dict[str, Any] = {}

    async def start(self, scheduler: Scheduler) -> None:
        self.workers = scheduler.workers

    def transition(self, key: object, start: str, finish: str, *args: Any, **kwargs: Any) -> None:
        if finish == "processing":
            held = [
                sum(str(task.key).startswith("dtc-") for task in worker.processing)
                for worker in self.workers.values()
            ]
            self.most = (max(self.most[0], *held), max(self.most[1], sum(held)))


def most_held(dask_scheduler: Scheduler) -> tuple[int, int]:
    """On the scheduler: what its :class:`MostHeld` saw, one worker's and all's."""
    return dask_scheduler.plugins[MostHeld.name].most  # type: ignore[attr-defined, no-any-return]


def test_a_worker_is_sent_no_task_but_the_one_its_thread_runs(
    beatlog: Callable[..., Run], cluster: str, many: Path
) -> None:
    with Client(cluster, set_as_default=False) as watcher:
        watcher.wait_for_workers(2)  # a worker a test before killed is back
        watcher.register_plugin(MostHeld())
        try:
            run = beatlog("test", many, "--dask", cluster)
            held = watcher.run_on_scheduler(most_held)
        finally:
            watcher.unregister_scheduler_plugin(MostHeld.name)

    assert closing_counts(run.out) == "22 passed, 1 failed, 1 error"
    assert held == (1, 2)  # the next of its thread is submitted once it ends


@pytest.mark.slow  # a worker started during the run: 5 s or more
def test_a_worker_that_joins_during_a_run_gets_tasks_of_it(
    beatlog: Callable[..., Run], tmp_path: Path, record_probe: RecordFn
) -> None:
    log, release = record_probe(60), tmp_path / "release"
    waiting = write_waiting(tmp_path / "suite", release)  # until the second worker is up
    for index in range(12):  # on one thread: the first alone, then tasks of three
        write_spec(tmp_path / "suite", f"d{index:02}", log, waiting)

    with local_cluster(1) as elastic, Client(elastic, set_as_default=False) as watcher:
        watcher.register_plugin(MostHeld())

        def grow() -> None:
            elastic.scale(2)
            watcher.wait_for_workers(2)
            time.sleep(2 * THREADS_ASKED_EVERY_S)  # the run has heard of it
            release.touch()

        grower = threading.Thread(target=grow)
        grower.start()
        try:
            run = beatlog("test", tmp_path / "suite", "--dask", elastic.scheduler_address)
        finally:
            grower.join()
        held = watcher.run_on_scheduler(most_held)

    assert closing_counts(run.out) == "12 passed, 0 failed"
    assert held == (1, 2)  # both workers replayed, one task each


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_a_dtc_that_kills_the_workers_of_its_task_loses_no_other_dtcs_outcome(
    beatlog: Callable[..., Run], tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(40)
    folder = tmp_path / "many"
    for index in range(16):  # on two threads, tasks of two DTCs after each thread's first
        write_spec(folder, f"dtc-{index:02}", log, DYING if index == 4 else PROBE)

    with local_cluster(2, allowed_failures=0) as fragile:  # a task lost with its first worker
        run = beatlog("test", folder, "--dask", fragile.scheduler_address)

    assert_workers_died(run, folder / "dtc-04.dtc.toml", "2 workers")
    assert closing_counts(run.out) == "15 passed, 0 failed, 1 error"
    assert "retried dtc-05: the worker replaying it died (1 time)" in whole_lines(run.out)


@pytest.mark.slow  # a cluster of its own, and a worker restarted: 5 s or more
def test_a_worker_that_dies_holding_outcomes_not_yet_fetched_loses_none(
    beatlog: Callable[..., Run], many: Path, tmp_path: Path
) -> None:
    local = beatlog("test", many, "-j", "1", "--junit-xml", tmp_path / "local.xml")
    marker = tmp_path / "fetched"
    with local_cluster(2) as cluster, Client(cluster, set_as_default=False) as watcher:
        watcher.register_plugin(DyingWhenFetched(marker))
        remote = beatlog(
            "test", many, "--dask", cluster.scheduler_address, "--junit-xml", tmp_path / "dask.xml"
        )

    assert marker.exists()
    assert remote.code == local.code == 2
    assert closing_counts(remote.out) == closing_counts(local.out) == "22 passed, 1 failed, 1 error"
    # the DTCs of the next task its thread had begun are run again, and the report says so
    retried = [name for name, tags in junit_cases(tmp_path / "dask.xml") if "flakyError" in tags]
    assert len(retried) <= 3  # tasks of three DTCs
    assert [
        (name, [tag for tag in tags if tag != "flakyError"])
        for name, tags in junit_cases(tmp_path / "dask.xml")
    ] == junit_cases(tmp_path / "local.xml")


@pytest.mark.slow  # a cluster of its own, and a worker restarted: 5 s or more
def test_a_dtc_whose_outcomes_were_lost_and_whose_replay_again_kills_its_worker_is_an_error(
    beatlog: Callable[..., Run], tmp_path: Path, record_probe: RecordFn
) -> None:
    folder = tmp_path / "suite"
    write_spec(
        folder, "again", record_probe(40), write_dying_once(folder, tmp_path / "built", first=False)
    )
    with (
        local_cluster(2, allowed_failures=0) as fragile,
        Client(fragile, set_as_default=False) as watcher,
    ):
        watcher.register_plugin(DyingWhenFetched(tmp_path / "fetched"))
        run = beatlog("test", folder, "--dask", fragile.scheduler_address)

    assert_workers_died(run, folder / "again.dtc.toml", "1 worker")
    assert closing_counts(run.out) == "0 passed, 0 failed, 1 error"
