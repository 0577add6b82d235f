"""Which DTCs a suite session runs: those found, selected by ``-k``, the tags and the
shard, named apart where they share a name; and the break points a selection takes."""

from __future__ import annotations

import collections
import shutil
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import fsspec
import fsspec.config
import pytest

from beatlog.baseline.file import expected_path, pending_path
from beatlog.baseline.policy import UpdateMode
from beatlog.errors import FleetError, OptionError, RemoteLogError, SystemLoadError
from beatlog.suite.maintenance import update_baselines
from beatlog.suite.parallel import Shard, longest_first, run_suite, split
from beatlog.suite.runner import Verdict
from beatlog.suite.selection import (
    FLEET_PURPOSE,
    SuiteOptions,
    check_break_at,
    fleet_of,
    fleet_specs,
    last_failed_path,
    remember_failed,
    rerun_failed,
    select_suite,
)
from beatlog.suite.spec import DtcSpec, find_rootdir, load_spec
from tests.conftest import RecordFn
from tests.served import LogServer
from tests.specs import CHANGED, PROBE, write_spec


@pytest.fixture
def specs(tmp_path: Path, record_probe: RecordFn) -> Path:
    """A folder of three DTCs of one 300-cycle log, two named ``approach``."""
    log = record_probe(300)
    folder = tmp_path / "specs"
    write_spec(folder, "approach", log, tags=["smoke"])
    write_spec(folder / "night", "approach", log)
    write_spec(folder, "retreat", log)
    return folder


def names(specs: Sequence[DtcSpec]) -> list[str]:
    return [spec.label for spec in specs]


def test_every_dtc_found_is_selected_without_an_expression(specs: Path) -> None:
    selection = select_suite(SuiteOptions(paths=(specs,)))

    assert names(selection.specs) == [
        "approach.dtc.toml::approach",
        "night/approach.dtc.toml::approach",
        "retreat",
    ]
    assert len(selection.found) == 3
    assert selection.rootdir == find_rootdir([specs])


def test_k_the_tags_and_the_shard_narrow_the_selection(specs: Path) -> None:
    by_k = select_suite(SuiteOptions(paths=(specs,), pattern="retreat"))
    by_tag = select_suite(SuiteOptions(paths=(specs,), tags=("smoke",)))
    sharded = select_suite(SuiteOptions(paths=(specs,), shard=Shard(1, 3)))

    assert names(by_k.specs) == ["retreat"]
    assert names(by_tag.specs) == ["approach"]
    assert len(sharded.specs) == 1
    assert len(by_k.found) == len(by_tag.found) == len(sharded.found) == 3


def test_a_selection_of_nothing_is_an_option_error(specs: Path, tmp_path: Path) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()

    with pytest.raises(OptionError) as unmatched:
        select_suite(SuiteOptions(paths=(specs,), pattern="nothing"))
    with pytest.raises(OptionError) as unfound:
        select_suite(SuiteOptions(paths=(empty,)))

    assert str(unmatched.value) == f"none of the 3 DTC specs in {specs} match -k/--tag"
    assert str(unfound.value) == f"no DTC specs to run in {empty} (looked for *.dtc.toml)"


def test_a_folder_without_specs_names_a_misnamed_spec_else_a_log_without_one(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(10)
    (tmp_path / "pyproject.toml").write_text("[tool.ruff]\nline-length = 100\n")
    misnamed = write_spec(tmp_path, "walk", log).rename(tmp_path / "walk.toml")

    with pytest.raises(OptionError) as spec_misnamed:
        select_suite(SuiteOptions(paths=(tmp_path,)))
    misnamed.unlink()
    with pytest.raises(OptionError) as log_alone:
        select_suite(SuiteOptions(paths=(tmp_path,)))

    assert str(spec_misnamed.value) == (
        f"no DTC specs to run in {tmp_path} (looked for *.dtc.toml; "
        f"{misnamed} is not one, a spec's name ends in .dtc.toml)"
    )
    assert str(log_alone.value) == (
        f"no DTC specs to run in {tmp_path} (looked for *.dtc.toml; {log} has none: "
        "a NAME.dtc.toml beside it makes it a DTC, see beatlog help spec)"
    )


def test_a_fleet_run_selects_its_logs_without_a_rootdir(record_probe: RecordFn) -> None:
    log = record_probe(30)
    options = SuiteOptions(logs=str(log), system=PROBE)

    selection = select_suite(options, fleet_of(options))

    assert [spec.log for spec in selection.specs] == [log]
    assert selection.rootdir is None


def test_specs_are_no_fleet() -> None:
    assert fleet_of(SuiteOptions()) is None


def test_a_break_stops_in_one_dtc(specs: Path) -> None:
    two = select_suite(SuiteOptions(paths=(specs,), pattern="approach")).specs

    with pytest.raises(OptionError) as refused:
        check_break_at(12, two, option="--break-at")

    assert str(refused.value) == (
        "--break-at stops in one DTC, and 2 are selected: name its spec or select it with -k"
    )


def test_a_break_past_the_end_of_the_log_is_refused(specs: Path) -> None:
    spec = load_spec(specs / "retreat.dtc.toml")

    check_break_at(299, [spec], option="--beatlog-break-at")
    with pytest.raises(OptionError) as refused:
        check_break_at(300, [spec], option="--beatlog-break-at")

    assert str(refused.value) == (
        f"--beatlog-break-at 300: {spec.log} has only 300 cycles; no break would be reached"
    )


def test_no_break_takes_any_selection(specs: Path) -> None:
    check_break_at(None, select_suite(SuiteOptions(paths=(specs,))).specs, option="--break-at")


def test_variants_asked_of_dtcs_that_declare_none_are_noted(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(50)
    write_spec(tmp_path, "plain", log)

    selection = select_suite(SuiteOptions(paths=(tmp_path,), variants=3))

    assert [spec.name for spec in selection.specs] == ["plain"]
    assert selection.note == (
        "--variants: no DTC selected declares variants "
        "([variants] in its spec, or [tool.beatlog.variants])"
    )


def test_variants_follow_each_dtc_that_declares_them(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(50)
    write_spec(tmp_path, "varied", log, variants={"count": 1})
    write_spec(tmp_path, "zplain", log)

    selection = select_suite(SuiteOptions(paths=(tmp_path,), variants=2))

    assert [spec.name for spec in selection.specs] == [
        "varied",
        "varied[variant-1]",
        "varied[variant-2]",
        "zplain",
    ]
    assert selection.note is None


# SuiteOptions: options that do not go together are refused


@pytest.mark.parametrize(
    ("given", "problem"),
    [
        ({"system": PROBE}, "--system and --perception go with --logs: a spec names its own"),
        (
            {"perception": "tests.x:step"},
            "--system and --perception go with --logs: a spec names its own",
        ),
        ({"logs": "*.beatlog"}, "--logs needs --system MODULE:FACTORY to replay the logs against"),
        (
            {"logs": "*.beatlog", "system": PROBE, "paths": (Path("specs"),)},
            "give DTC specs or --logs, not both",
        ),
        (
            {"logs": "*.beatlog", "system": PROBE, "update": UpdateMode.NEW},
            "--update writes the baselines of specs; --logs runs have none",
        ),
        (
            {"logs": "*.beatlog", "system": PROBE, "last_failed": True},
            "--lf reruns the specs that failed; --logs runs are not remembered",
        ),
    ],
    ids=[
        "system-without-logs",
        "perception-without-logs",
        "logs-alone",
        "logs-and-specs",
        "update",
        "last-failed",
    ],
)
def test_options_that_do_not_go_together_are_refused(
    given: dict[str, object], problem: str
) -> None:
    with pytest.raises(OptionError) as refused:
        SuiteOptions(**given)  # type: ignore[arg-type]

    assert str(refused.value) == problem


def test_a_fleet_run_takes_its_logs_and_system() -> None:
    options = SuiteOptions(logs="fleet/*.beatlog", system=PROBE)

    assert (options.logs, options.system, options.paths) == ("fleet/*.beatlog", PROBE, (Path(),))


def test_the_reports_are_those_asked_for(tmp_path: Path) -> None:
    junit, html = tmp_path / "junit.xml", tmp_path / "report.html"

    assert SuiteOptions().reports == ()
    assert SuiteOptions(html=html, junit_xml=junit).reports == (junit, html)


@pytest.mark.parametrize(
    ("given", "breaking"),
    [({}, False), ({"break_at": 0}, True), ({"break_on_divergence": True}, True)],
)
def test_a_session_breaks_with_either_break_point(given: dict[str, object], breaking: bool) -> None:
    assert SuiteOptions(**given).breaking is breaking  # type: ignore[arg-type]


# --lf: the DTCs that failed last time


@pytest.fixture
def suite(tmp_path: Path, record_probe: RecordFn) -> list[DtcSpec]:
    """Two DTCs of one log: ``approach`` passes, ``changed`` fails."""
    log = record_probe(60)
    folder = tmp_path / "specs"
    return [
        load_spec(write_spec(folder, "approach", log)),
        load_spec(write_spec(folder, "changed", log, CHANGED)),
    ]


def test_the_failures_are_remembered_and_rerun(suite: list[DtcSpec]) -> None:
    path = last_failed_path(suite[0].path.parent)

    assert remember_failed(run_suite(suite), path) is None

    assert rerun_failed(suite, path) == (
        [suite[1]],
        "--lf: rerunning the 1 DTC that failed last time",
    )


def test_nothing_is_written_while_nothing_failed(suite: list[DtcSpec]) -> None:
    path = last_failed_path(suite[0].path.parent)

    assert remember_failed(run_suite(suite[:1]), path) is None

    assert not path.parent.exists()


def test_a_damaged_memory_is_ignored_with_a_warning(suite: list[DtcSpec]) -> None:
    path = last_failed_path(suite[0].path.parent)
    path.parent.mkdir()
    path.write_text("{not json", encoding="utf-8")

    chosen, said = rerun_failed(suite, path)

    assert chosen == suite
    assert said.startswith(
        "--lf: no DTC selected failed last time; running all 2 "
        f"({path}: not a beatlog memory of failed DTCs ("
    )
    assert said.endswith("; ignored, and replaced by what this run saw)")
    assert remember_failed(run_suite(suite), path) is not None
    assert rerun_failed(suite, path)[0] == [suite[1]]


# fleet runs: a DTC per log that matches a glob or an fsspec URL


@pytest.fixture
def logs(tmp_path: Path, record_probe: RecordFn) -> Path:
    """``logs/`` with two probe sessions, one in a subfolder, and a note that is no log."""
    (tmp_path / "logs" / "tuesday").mkdir(parents=True)
    record_probe(40, name="logs/monday.beatlog")
    record_probe(60, name="logs/tuesday/dock.beatlog")
    (tmp_path / "logs" / "notes.txt").write_text("not a log", encoding="utf-8")
    return tmp_path / "logs"


@pytest.fixture
def memory(logs: Path) -> Iterator[str]:
    """The logs in fsspec's in-memory filesystem, under a folder of this test's own."""
    filesystem = fsspec.filesystem("memory")
    folder = f"/{logs.parent.name}"
    filesystem.put(str(logs), folder, recursive=True)
    yield f"memory://{folder}"
    filesystem.rm(folder, recursive=True)


def test_each_matching_log_becomes_a_dtc_named_after_its_file(logs: Path) -> None:
    specs = fleet_specs(f"{logs}/**/*.beatlog", system=PROBE)

    assert [spec.name for spec in specs] == ["monday", "dock"]
    [monday, dock] = specs
    assert monday.log == monday.path == logs / "monday.beatlog"
    assert monday.source == monday.origin == str(logs / "monday.beatlog")
    assert monday.log_url is None
    assert dock.log == logs / "tuesday" / "dock.beatlog"
    assert (monday.purpose, monday.procedure) == (FLEET_PURPOSE, ())
    assert (monday.system, monday.perception, monday.tags) == (PROBE, None, ())


def test_a_fleet_run_judges_each_log_against_its_recording(logs: Path) -> None:
    outcomes = run_suite(fleet_specs(f"{logs}/*.beatlog", system=PROBE))

    assert [(o.spec.name, o.verdict) for o in outcomes] == [("monday", Verdict.PASSED)]


def test_a_fleet_log_ignores_files_beside_it_that_a_spec_would_read(logs: Path) -> None:
    log = logs / "monday.beatlog"
    expected_path(log).write_text("not a baseline", encoding="utf-8")

    [outcome] = run_suite(fleet_specs(str(log), system=CHANGED), update=UpdateMode.NEW)

    assert outcome.verdict is Verdict.FAILED
    assert outcome.baseline is None
    assert update_baselines([outcome], UpdateMode.NEW) == []
    assert not pending_path(log).exists()


def test_a_failing_fleet_log_is_rerun_by_a_fleet_run_of_that_log(logs: Path) -> None:
    [outcome] = run_suite(fleet_specs(f"{logs}/*.beatlog", system=CHANGED))

    assert outcome.result is not None
    assert (
        outcome.result.reproduce == f"beatlog test --logs {logs}/monday.beatlog --system {CHANGED}"
    )


def test_the_rerun_command_keeps_the_perception_step(logs: Path) -> None:
    [outcome] = run_suite(fleet_specs(f"{logs}/*.beatlog", system=CHANGED, perception="a.b:c"))

    assert outcome.reproduce == (
        f"beatlog test --logs {logs}/monday.beatlog --system {CHANGED} --perception a.b:c"
    )


def test_a_log_name_with_glob_characters_is_escaped_in_the_rerun_command(
    logs: Path,
) -> None:
    odd = logs / "run[1].beatlog"
    (logs / "monday.beatlog").rename(odd)

    [outcome] = run_suite(fleet_specs(f"{logs}/*.beatlog", system=CHANGED))

    assert outcome.reproduce == (
        f"beatlog test --logs '{logs}/run[[]1].beatlog' --system {CHANGED}"
    )


def test_logs_behind_a_url_are_listed_not_copied_and_replayed_from_copies(
    memory: str,
) -> None:
    specs = fleet_specs(f"{memory}/**/*.beatlog", system=PROBE)

    assert [spec.name for spec in specs] == ["monday", "dock"]
    assert [spec.log_url for spec in specs] == [
        f"{memory}/monday.beatlog",
        f"{memory}/tuesday/dock.beatlog",
    ]
    assert [spec.source for spec in specs] == [spec.log_url for spec in specs]
    assert [spec.log for spec in specs] == [Path("monday.beatlog"), Path("dock.beatlog")]
    outcomes = run_suite(specs)
    assert [outcome.verdict for outcome in outcomes] == [Verdict.PASSED] * 2
    assert [outcome.spec for outcome in outcomes] == specs


def test_the_listing_of_logs_behind_a_url_gives_their_sizes(memory: str, logs: Path) -> None:
    specs = fleet_specs(f"{memory}/**/*.beatlog", system=PROBE)

    assert [spec.log_size for spec in specs] == [
        (logs / "monday.beatlog").stat().st_size,
        (logs / "tuesday" / "dock.beatlog").stat().st_size,
    ]


def test_a_fleets_order_and_shards_come_from_its_listing_with_no_request_per_log(
    memory: str,
) -> None:
    specs = fleet_specs(f"{memory}/**/*.beatlog", system=PROBE)
    for spec in specs:  # sizes asked for now could not be had
        fsspec.filesystem("memory").rm(spec.log_url)

    assert [spec.name for spec in longest_first(specs)] == ["dock", "monday"]
    assert split(specs, 2) == [[specs[1]], [specs[0]]]


def test_listing_logs_behind_an_http_url_downloads_none(served: LogServer) -> None:
    specs = fleet_specs(f"{served.url}/*.beatlog", system=PROBE)

    assert [spec.log_url for spec in specs] == [
        f"{served.url}/dock.beatlog",
        f"{served.url}/yard.beatlog",
    ]
    assert [served.downloads(name) for name in ("dock.beatlog", "yard.beatlog")] == [0, 0]


def test_a_file_url_reads_the_local_folder(logs: Path) -> None:
    specs = fleet_specs(f"file://{logs}/*.beatlog", system=PROBE)

    assert [spec.source for spec in specs] == [f"file://{logs}/monday.beatlog"]
    assert [outcome.verdict for outcome in run_suite(specs)] == [Verdict.PASSED]


@pytest.mark.parametrize("where", ["local", "url"])
def test_a_pattern_that_matches_no_log_is_named(logs: Path, memory: str, where: str) -> None:
    pattern = f"{logs if where == 'local' else memory}/*.mcap"

    with pytest.raises(FleetError) as raised:
        fleet_specs(pattern, system=PROBE)

    assert str(raised.value) == f"--logs {pattern}: no log matches"


def test_a_url_without_fsspec_says_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in [name for name in sys.modules if name.startswith("fsspec")]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, "fsspec", None)

    with pytest.raises(FleetError) as raised:
        fleet_specs("s3://bucket/*.beatlog", system=PROBE)

    assert str(raised.value) == (
        '--logs s3://bucket/*.beatlog: a URL needs fsspec (pip install "beatlog[fleet]")'
    )


def test_an_unknown_url_scheme_cannot_be_opened() -> None:
    with pytest.raises(FleetError, match=r"^--logs nowhere://x/\*: cannot open: "):
        fleet_specs("nowhere://x/*", system=PROBE)


@pytest.mark.parametrize(
    ("system", "perception", "problem"),
    [
        ("tests.conftest", None, "--system: expected module:factory, got 'tests.conftest'"),
        (PROBE, "perceive", "--perception: expected module:factory, got 'perceive'"),
    ],
)
def test_a_system_reference_without_a_factory_is_refused(
    logs: Path, system: str, perception: str | None, problem: str
) -> None:
    with pytest.raises(FleetError) as raised:
        fleet_specs(f"{logs}/*.beatlog", system=system, perception=perception)

    assert str(raised.value) == problem


def test_a_fleet_log_over_http_is_named_as_the_file_is(served: LogServer) -> None:
    shutil.copyfile(served.folder / "dock.beatlog", served.folder / "dock at noon.beatlog")

    specs = fleet_specs(f"{served.url}/dock at*.beatlog", system=PROBE)

    assert [spec.name for spec in specs] == ["dock at noon"]
    assert specs[0].log_url == f"{served.url}/dock%20at%20noon.beatlog"


def test_code_beside_fleet_logs_is_never_imported(logs: Path) -> None:
    planted = logs / "planted_beside_logs"
    planted.mkdir()
    (planted / "__init__.py").write_text("raise SystemExit('planted code ran')\n")
    fleet = SuiteOptions(logs=f"{logs}/*.beatlog", system="planted_beside_logs:system")
    [spec] = fleet_specs(f"{logs}/*.beatlog", system="planted_beside_logs:system")

    with pytest.raises(SystemLoadError, match=r"^--system .*cannot import planted_beside_logs"):
        fleet_of(fleet)
    [outcome] = run_suite([spec])

    assert outcome.verdict is Verdict.ERROR
    assert "planted code ran" not in str(outcome.error)
    assert "planted_beside_logs" not in sys.modules


# a fleet in S3: one request a log, none once cached


@dataclass
class S3Server:
    """An S3-compatible server on the loopback (moto's), counting its requests by
    method, a listing as ``LIST``."""

    url: str
    requests: collections.Counter[str] = field(default_factory=collections.Counter)


@pytest.fixture
def s3(monkeypatch: pytest.MonkeyPatch) -> Iterator[S3Server]:
    """A server of moto's, where moto and s3fs are installed; s3fs reaches it. Its
    buckets are the process's (moto's): each test makes its own."""
    pytest.importorskip("s3fs")
    werkzeug_app = pytest.importorskip("moto.moto_server.werkzeug_app")
    serving = pytest.importorskip("werkzeug.serving")
    app = werkzeug_app.DomainDispatcherApplication(werkzeug_app.create_backend_app)
    server = S3Server("")

    def counted(environ: dict[str, Any], start: Callable[..., Any]) -> Any:
        listing = "list-type" in environ["QUERY_STRING"]
        server.requests["LIST" if listing else environ["REQUEST_METHOD"]] += 1
        return app(environ, start)

    httpd = serving.make_server("127.0.0.1", 0, counted, threaded=True)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    server.url = f"http://127.0.0.1:{httpd.server_address[1]}"
    for name, value in (("AWS_ACCESS_KEY_ID", "k"), ("AWS_SECRET_ACCESS_KEY", "s")):
        monkeypatch.setenv(name, value)
    monkeypatch.setenv("AWS_DEFAULT_REGION", "us-east-1")
    monkeypatch.setitem(fsspec.config.conf, "s3", {"endpoint_url": server.url})
    try:
        yield server
    finally:
        httpd.shutdown()
        thread.join()


@pytest.mark.slow
def test_a_fleet_in_s3_is_one_request_a_log_then_none_from_the_cache(
    s3: S3Server, logs: Path
) -> None:
    storage = fsspec.filesystem("s3", endpoint_url=s3.url, skip_instance_cache=True)
    storage.mkdir("fleet")
    for log in ("monday.beatlog", "tuesday/dock.beatlog"):
        storage.pipe(f"fleet/{Path(log).name}", (logs / log).read_bytes())
    s3.requests.clear()

    specs = fleet_specs("s3://fleet/*.beatlog", system=PROBE)
    fsspec.get_filesystem_class("s3").clear_instance_cache()  # as on a worker: no listing seen
    copies = []
    for _ in range(2):
        for spec in specs:
            with spec.readable_log() as copy:
                copies.append(copy.read_bytes())

    assert s3.requests == {"LIST": 1, "GET": 2}
    assert (
        copies[:2]
        == copies[2:]
        == [
            (logs / "tuesday" / "dock.beatlog").read_bytes(),
            (logs / "monday.beatlog").read_bytes(),
        ]
    )
    assert all(spec.log_etag for spec in specs)


@pytest.mark.slow
def test_a_log_changed_in_s3_since_its_listing_is_an_error_never_a_copy(
    s3: S3Server, logs: Path
) -> None:
    storage = fsspec.filesystem("s3", endpoint_url=s3.url, skip_instance_cache=True)
    storage.mkdir("changed")
    whole = (logs / "monday.beatlog").read_bytes()
    storage.pipe("changed/monday.beatlog", whole)
    [spec] = fleet_specs("s3://changed/*.beatlog", system=PROBE)
    storage.pipe("changed/monday.beatlog", whole[::-1])  # the same size
    fsspec.get_filesystem_class("s3").clear_instance_cache()

    for _ in range(2):  # nothing of it kept
        with pytest.raises(RemoteLogError) as raised, spec.readable_log():
            pass
        assert str(raised.value).startswith("s3://changed/monday.beatlog: cannot copy: ")
        assert "no longer exists" in str(raised.value)
