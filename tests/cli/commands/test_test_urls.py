"""``beatlog test`` with logs behind URLs: a spec's ``log`` may be a URL, and each log
is downloaded once a run, by the process that replays it; its problems are errors of
its DTC, one line naming the spec and the URL."""

from __future__ import annotations

import os
import re
import signal
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from beatlog.baseline.file import pending_path
from beatlog.suite.remote import MAX_BYTES_VARIABLE
from tests.commands import Beatlog, closing_counts, signalled
from tests.conftest import RecordFn
from tests.served import LogServer
from tests.specs import CHANGED, PROBE, write_spec
from tests.text import table_row, whole_lines

pytestmark = pytest.mark.usefixtures("wide_plain_console")

LOGS = ("dock.beatlog", "yard.beatlog")


@pytest.fixture
def suite(served: LogServer, tmp_path: Path) -> Path:
    """Two specs whose logs are URLs: one passes, one replays a changed system."""
    folder = tmp_path / "suite"
    write_spec(folder, "dock", f"{served.url}/dock.beatlog")
    write_spec(folder, "yard", f"{served.url}/yard.beatlog", CHANGED)
    return folder


def test_specs_whose_logs_are_urls_are_judged_each_log_downloaded_once(
    beatlog: Beatlog, served: LogServer, suite: Path, tmp_path: Path
) -> None:
    junit, page = tmp_path / "dtc.xml", tmp_path / "report.html"

    run = beatlog("test", suite, "-j", "2", "--junit-xml", junit, "--html", page)

    assert run.code == 1, run.err
    assert closing_counts(run.out) == "1 passed, 1 failed"
    assert f"reproduce: beatlog test {suite / 'yard.dtc.toml'}" in whole_lines(run.out)
    assert [served.downloads(name) for name in LOGS] == [1, 1]
    cases = ET.parse(junit).getroot().iter("testcase")
    assert [case.get("file") for case in cases] == [
        str(suite / "dock.dtc.toml"),
        str(suite / "yard.dtc.toml"),
    ]
    assert re.findall(r"<dt>log</dt><dd>([^<]*)</dd>", page.read_text()) == [
        f"{served.url}/dock.beatlog",
        f"{served.url}/yard.beatlog",
    ]


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_a_rerun_and_an_audit_download_no_log_again(
    beatlog: Beatlog, served: LogServer, suite: Path
) -> None:
    runs = [beatlog("test", suite), beatlog("test", suite), beatlog("test", suite, "--audit")]

    assert [closing_counts(run.out) for run in runs] == ["1 passed, 1 failed"] * 3
    assert [served.downloads(name) for name in LOGS] == [1, 1]


def test_verbose_says_how_long_a_dtc_waited_for_its_log_behind_a_url(
    beatlog: Beatlog, suite: Path
) -> None:
    run = beatlog("test", suite, "-v")

    assert re.search(r"PASS dock: \d+ cycles, .* checked; \d+\.\d\d s waiting for storage", run.out)


def test_a_log_url_not_found_is_an_error_of_its_dtc_naming_spec_and_url(
    beatlog: Beatlog, served: LogServer, suite: Path
) -> None:
    write_spec(suite, "lost", f"{served.url}/lost.beatlog")

    run = beatlog("test", suite)

    assert run.code == 2
    spec = suite / "lost.dtc.toml"
    assert run.err == f"beatlog: error: lost ({spec}): {served.url}/lost.beatlog: no such log\n"
    assert closing_counts(run.out) == "1 passed, 1 failed, 1 error"


def test_a_fleet_matrix_downloads_each_log_once_in_all(beatlog: Beatlog, served: LogServer) -> None:
    pattern = f"{served.url}/*.beatlog"

    runs = [
        beatlog("test", "--logs", pattern, "--system", PROBE, "--shard", shard)
        for shard in ("1/2", "2/2")
    ]

    assert [closing_counts(run.out) for run in runs] == ["1 passed, 0 failed"] * 2
    assert [served.downloads(name) for name in LOGS] == [1, 1]


@pytest.mark.usefixtures("outside_ci")
def test_the_pending_baseline_of_a_log_behind_a_url_names_it_and_can_be_approved(
    beatlog: Beatlog, served: LogServer, suite: Path
) -> None:
    yard = suite / "yard.dtc.toml"

    updated = beatlog("test", yard, "--update")
    approved = beatlog("approve", yard)
    again = beatlog("test", yard)

    assert updated.code == 1, updated.err
    log_line = (suite / "yard.dtc.expected").read_text().splitlines()[2]
    assert re.fullmatch(
        rf"# log {re.escape(served.url)}/yard\.beatlog sha256 [0-9a-f]{{64}}", log_line
    )
    assert not pending_path(yard).exists()
    assert approved.code == 0, approved.err
    assert again.code == 0, again.err
    assert re.search(r"passed \(approved baseline, open loop since cycle \d+\)", again.out)


def test_coverage_reads_logs_behind_urls_too(
    beatlog: Beatlog, served: LogServer, suite: Path
) -> None:
    run = beatlog("test", suite, "--coverage", "-k", "dock")

    assert run.code == 0, run.err
    assert table_row(run.out, "near")[2] == '"far" → "near" ×3 in 1 DTC; "near" → "far" ×3 in 1 DTC'
    assert served.downloads("dock.beatlog") == 1  # one copy: the replay reads the coverage too


def test_a_log_behind_a_url_that_is_no_log_is_named_by_its_url(
    beatlog: Beatlog, served: LogServer, suite: Path
) -> None:
    (served.folder / "broken.beatlog").write_bytes(b"not a log")
    write_spec(suite, "broken", f"{served.url}/broken.beatlog")

    run = beatlog("test", suite / "broken.dtc.toml")

    assert run.code == 2
    assert run.err == (
        f"beatlog: error: broken ({suite / 'broken.dtc.toml'}): {served.url}/broken.beatlog: "
        "not a session log (not an MCAP file)\n"
    )


def test_a_spec_allowing_truncation_fails_on_a_log_url_cut_off(
    beatlog: Beatlog, served: LogServer, suite: Path, record_chunked: RecordFn
) -> None:
    record_chunked(300, name="served/long.beatlog")
    url = f"{served.url}/cut-close/long.beatlog"
    write_spec(suite, "long", url, allow_truncated=True)

    run = beatlog("test", suite / "long.dtc.toml")

    assert run.code == 2
    assert run.err == (
        f"beatlog: error: long ({suite / 'long.dtc.toml'}): {url}: the server sent neither "
        "its length nor a chunked body: a download cut off could not be told from the whole "
        "log\n"
    )


@pytest.mark.parametrize(
    ("signum", "code", "said"),
    [(signal.SIGTERM, 143, "terminated"), (signal.SIGINT, 130, "interrupted")],
    ids=["SIGTERM", "Ctrl-C"],
)
@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_a_stopped_run_removes_the_copies_its_workers_were_downloading(
    served: LogServer, tmp_path: Path, signum: int, code: int, said: str
) -> None:
    folder = tmp_path / "endless"
    for name in ("dock", "yard"):
        write_spec(folder, name, f"{served.url}/endless/{name}.beatlog")
    temporary = tmp_path / "temporary"
    temporary.mkdir()
    env = {**os.environ, "TMPDIR": str(temporary), MAX_BYTES_VARIABLE: str(1 << 40)}

    def both_downloading() -> bool:
        return len(list(temporary.glob("beatlog-remote-*/*.beatlog"))) == 2

    run = signalled(
        ["test", folder, "-j", "2"],
        both_downloading,
        signum,
        env=env,
        group=signum == signal.SIGINT,
    )

    assert (run.code, run.err) == (code, f"beatlog: {said}\n")
    assert list(temporary.iterdir()) == []
