"""``beatlog replay``, ``show``, ``plot`` and ``export`` on a log behind a URL: the log is
downloaded once per command, and everything the command prints names the URL, never
the copy it read."""

from __future__ import annotations

import json
import os
import re
import signal
import sys
from pathlib import Path

import pytest

from beatlog.suite.remote import MAX_BYTES_VARIABLE, TIMEOUT_VARIABLE
from tests.commands import (
    Beatlog,
    Run,
    assert_error,
    beatlog_process,
    plain,
    replay_line,
    signalled,
)
from tests.conftest import RecordFn
from tests.factories import vouch
from tests.served import LogServer
from tests.specs import CHANGED, PROBE, PROBE_CHECKED

pytestmark = pytest.mark.usefixtures("wide_plain_console")


def test_replay_judges_a_log_behind_a_url_and_names_the_url(
    beatlog: Beatlog, served: LogServer
) -> None:
    url = f"{served.url}/dock.beatlog"

    run = beatlog("replay", url, "--system", PROBE)

    assert run.code == 0, run.err
    assert re.fullmatch(replay_line("PASS", url, PROBE_CHECKED) + "\n", run.out), run.out
    assert served.downloads("dock.beatlog") == 1


def test_a_diverging_replay_of_a_url_reproduces_with_the_url(
    beatlog: Beatlog, served: LogServer
) -> None:
    url = f"{served.url}/dock.beatlog"

    run = beatlog("replay", url, "--system", CHANGED)

    assert run.code == 1, run.err
    first = run.out.splitlines()[0]
    assert re.fullmatch(replay_line("FAIL", url, "22 cycles, 0.7 s robot time"), first), first
    assert run.out.splitlines()[-1] == f"reproduce: beatlog replay {url} --system {CHANGED}"
    assert "beatlog-remote-" not in run.out
    assert served.downloads("dock.beatlog") == 1


def test_replay_json_names_the_url_and_the_copy_it_read(
    beatlog: Beatlog, served: LogServer
) -> None:
    url = f"{served.url}/yard.beatlog"

    run = beatlog("replay", url, "--system", PROBE, "--json")

    result = json.loads(run.out)
    assert result["ok"] is True
    assert result["url"] == url
    assert Path(result["log"]).name == "yard.beatlog"


def test_replay_against_the_vouched_recorded_system_says_it_of_the_url(
    beatlog: Beatlog, served: LogServer, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    url = f"{served.url}/dock.beatlog"
    vouch(tmp_path, PROBE)
    monkeypatch.chdir(tmp_path)

    run = beatlog("replay", url)

    assert run.code == 0, run.err
    assert run.err == (
        f"beatlog: replaying against {PROBE}, as recorded in {url} "
        "and listed in the project's [tool.beatlog] systems\n"
    )
    assert served.downloads("dock.beatlog") == 1


def test_a_log_behind_a_url_never_chooses_the_system_on_its_own(
    beatlog: Beatlog, served: LogServer, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    url = f"{served.url}/dock.beatlog"
    monkeypatch.chdir(tmp_path)

    run = beatlog("replay", url)

    assert_error(
        run,
        f"{url}: records the system {PROBE!r}, which this project does not vouch for; name it "
        "(--system, or system = in the spec) or list it under [tool.beatlog] systems in a "
        "pyproject.toml",
    )


def test_show_describes_a_log_behind_a_url(beatlog: Beatlog, served: LogServer) -> None:
    url = f"{served.url}/yard.beatlog"

    run = beatlog("show", url)

    assert run.code == 0, run.err
    rows = {line.split()[0]: line.split()[1:] for line in run.out.splitlines()[:9]}
    assert rows["log"] == [url]
    assert rows["cycles"] == ["200"]
    assert served.downloads("yard.beatlog") == 1


def test_export_writes_a_log_behind_a_url(
    beatlog: Beatlog, served: LogServer, tmp_path: Path
) -> None:
    url, output = f"{served.url}/yard.beatlog", tmp_path / "yard.mcap"

    run = beatlog("export", url, "-o", output, "--system", PROBE)

    assert run.code == 0, run.err
    assert run.out == f"exported 200 cycles of {url} to {output} (mcap); the replay passed\n"
    assert output.read_bytes().startswith(b"\x89MCAP")
    assert served.downloads("yard.beatlog") == 1


def test_plot_draws_a_log_behind_a_url_downloading_it_once(
    beatlog: Beatlog, served: LogServer, tmp_path: Path
) -> None:
    pytest.importorskip("matplotlib")
    url, svg = f"{served.url}/dock.beatlog", tmp_path / "dock.svg"

    run = beatlog("plot", url, "-o", svg, "--system", CHANGED)

    assert run.code == 0, run.err
    assert run.out.startswith(f"drew 300 cycles of {url} to {svg}; first divergence at cycle ")
    assert svg.read_text().startswith("<?xml")
    assert served.downloads("dock.beatlog") == 1


@pytest.mark.parametrize("command", ["replay", "show"])
def test_a_log_url_not_found_is_one_line_naming_it(
    beatlog: Beatlog, served: LogServer, command: str
) -> None:
    url = f"{served.url}/lost.beatlog"

    run = beatlog(command, url)

    assert_error(run, f"{url}: no such log")


@pytest.mark.parametrize(
    "command",
    [["replay", "--system", PROBE], ["show"], ["export", "--format", "csv", "-o", "notes.csv"]],
    ids=["replay", "show", "export"],
)
def test_a_damaged_log_behind_a_url_is_one_line_naming_the_url_not_the_copy(
    beatlog: Beatlog, served: LogServer, command: list[str]
) -> None:
    (served.folder / "notes.beatlog").write_bytes(b"not a session log at all\n" * 40)
    url = f"{served.url}/notes.beatlog"

    run = beatlog(command[0], url, *command[1:])

    assert_error(run, f"{url}: not a session log (not an MCAP file)")


@pytest.mark.parametrize(
    ("way", "problem"),
    [
        ("stall", "cannot copy: no answer for 1 s (BEATLOG_URL_TIMEOUT)"),
        (
            "trickle",
            "too slow: a download must average 64 KiB/s past its first 1 s (BEATLOG_URL_TIMEOUT)",
        ),
    ],
)
@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_a_log_url_whose_server_stalls_or_trickles_is_given_up(
    served: LogServer, way: str, problem: str
) -> None:
    url = f"{served.url}/{way}/dock.beatlog"

    run = beatlog_process(
        ["replay", url, "--system", PROBE], env={**os.environ, TIMEOUT_VARIABLE: "1"}
    )

    assert run == Run(2, "", f"beatlog: error: {url}: {problem}\n")


def test_a_log_url_cut_off_without_a_length_is_no_truncated_log(
    beatlog: Beatlog, served: LogServer, record_chunked: RecordFn
) -> None:
    record_chunked(300, name="served/long.beatlog")
    url = f"{served.url}/cut-close/long.beatlog"

    run = beatlog("replay", url, "--system", PROBE, "--allow-truncated")

    assert_error(
        run,
        f"{url}: the server sent neither its length nor a chunked body: "
        "a download cut off could not be told from the whole log",
    )


def test_show_draws_a_big_download_s_progress_on_a_terminal(
    beatlog: Beatlog, served: LogServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("beatlog.suite.remote.PROGRESS_BYTES", 0)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    url = f"{served.url}/dock.beatlog"

    run = beatlog("show", url)

    assert run.code == 0, run.err
    assert run.out.split()[:2] == ["log", url]
    drawn = [line for line in plain(run.err).split("\r") if line.startswith("dock.beatlog ━")]
    assert drawn, run.err


def test_sigterm_stops_a_download_and_removes_its_copy(served: LogServer, tmp_path: Path) -> None:
    temporary = tmp_path / "temporary"
    temporary.mkdir()
    env = {**os.environ, "TMPDIR": str(temporary), MAX_BYTES_VARIABLE: str(1 << 40)}

    def downloading() -> bool:
        return any(temporary.glob("beatlog-remote-*/dock.beatlog"))

    run = signalled(
        ["replay", f"{served.url}/endless/dock.beatlog", "--system", PROBE],
        downloading,
        signal.SIGTERM,
        env=env,
    )

    assert run == Run(143, "", "beatlog: terminated\n")
    assert list(temporary.iterdir()) == []
