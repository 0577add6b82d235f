"""``beatlog record``: a complete log in real time, its references checked before it
starts, one line for bad input. When the disk cannot take the log: never a traceback;
the summary line says where the log stops, and the log is valid up to there."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.record.recorder import Recorder
from beatlog_examples.rover import system
from tests.commands import ROOT, Beatlog, assert_error, assert_error_matching, cannot_import
from tests.conftest import RecordFn
from tests.factories import fill_the_disk
from tests.specs import PROBE

LIMITED = """
import resource, signal, sys
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG
resource.setrlimit(resource.RLIMIT_FSIZE, (int(sys.argv[1]), int(sys.argv[1])))
from beatlog.cli.main import main
sys.exit(main(sys.argv[2:]))
"""
"""``beatlog ARGS`` whose files cannot grow past a size: a real full disk, for one process."""


def beatlog_record(
    output: Path, *args: str, max_file_size: int
) -> subprocess.CompletedProcess[str]:
    command = ["record", "--robot", "beatlog_examples.rover:robot", "-o", str(output), *args]
    return subprocess.run(
        [sys.executable, "-c", LIMITED, str(max_file_size), *command],
        cwd=ROOT,
        env={**os.environ, "COLUMNS": "300"},
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )


def empty_log_size() -> int:
    """The bytes of a rover log with no cycle: header, schemas and end."""
    file = io.BytesIO()
    with Recorder(file, system(), software="unknown", log_samples=True):
        pass
    return len(file.getvalue())


@pytest.mark.slow
def test_a_disk_that_fills_up_while_recording_gives_the_summary_and_exit_1(
    tmp_path: Path,
) -> None:
    out = tmp_path / "rover.beatlog"

    done = beatlog_record(
        out,
        "--duration",
        "3",
        "--log-samples",
        "--flush-interval",
        "0.1",
        max_file_size=empty_log_size() + 2_000,
    )

    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr
    assert not done.stdout.startswith("\n"), "no blank line where no progress bar was drawn"
    summary = done.stdout.strip().splitlines()[-1]
    found = re.fullmatch(
        rf"recorded (\d+) cycles \(3\.\d\d s, \d+ overruns\) to {re.escape(str(out))}; "
        r"recording failed at cycle (\d+): OSError: \[Errno 27\] File too large "
        r"\(the log is valid up to there\)",
        summary,
    )
    assert found is not None, summary
    with SessionLogReader(out) as reader:
        kept = len(list(reader.cycles()))
        assert (reader.status.complete, reader.status.cycles) == (False, kept)
    assert 0 < kept == int(found.group(2)) < int(found.group(1))


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (Linux)")
def test_a_disk_full_before_the_first_cycle_is_one_line() -> None:
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "beatlog.cli.main",
            "record",
            "--robot",
            "beatlog_examples.rover:robot",
            "-o",
            "/dev/full",
            "--force",
            "--duration",
            "1",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )

    assert done.returncode == 2
    assert done.stdout == ""
    assert done.stderr == "beatlog: error: /dev/full: cannot write: No space left on device\n"


def test_a_disk_full_before_the_header_leaves_no_file_and_one_line(
    beatlog: Beatlog, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "rover.beatlog"
    fill_the_disk(monkeypatch)

    run = beatlog("record", "--robot", "beatlog_examples.rover:robot", "-o", out, "--duration", "1")

    assert_error(run, f"{out}: cannot write: No space left on device")
    assert list(tmp_path.iterdir()) == []


def test_record_refuses_to_overwrite_a_log(beatlog: Beatlog, record_probe: RecordFn) -> None:
    log = record_probe(10)
    before = log.read_bytes()

    run = beatlog("record", "--robot", "beatlog_examples.rover:robot", "-o", log, "--duration", 1)

    assert_error(run, f"{log}: already exists; recordings are immutable (use --force)")
    assert log.read_bytes() == before


def test_record_into_a_missing_directory_is_one_line(beatlog: Beatlog, tmp_path: Path) -> None:
    out = tmp_path / "nowhere" / "rover.beatlog"

    run = beatlog("record", "--robot", "beatlog_examples.rover:robot", "-o", out, "--duration", 1)

    assert_error(run, f"{out}: directory {out.parent} does not exist")


def test_record_checks_the_system_reference_before_recording(
    beatlog: Beatlog, tmp_path: Path
) -> None:
    out = tmp_path / "rover.beatlog"

    run = beatlog(
        "record",
        "--robot",
        "beatlog_examples.rover:robot",
        "--system-ref",
        "nosuch:thing",
        "-o",
        out,
        "--duration",
        1,
    )

    assert_error_matching(run, re.escape("'nosuch:thing': ") + cannot_import("nosuch"))
    assert not out.exists()


def test_record_needs_a_robot_not_a_system(beatlog: Beatlog, tmp_path: Path) -> None:
    out = tmp_path / "probe.beatlog"

    run = beatlog("record", "--robot", PROBE, "-o", out, "--duration", 1)

    assert_error(
        run,
        f"'{PROBE}': built a PriorityArbiter, not a robot "
        "(it needs system, inbox, start, stop, perceive and act)",
    )
    assert not out.exists()


def test_record_writes_a_complete_log_that_replays(beatlog: Beatlog, tmp_path: Path) -> None:
    out = tmp_path / "rover.beatlog"

    recorded = beatlog(
        "record",
        "--robot",
        "beatlog_examples.rover:robot",
        "-o",
        out,
        "--duration",
        0.5,
        "--seed",
        11,
        "--robot-id",
        "rover-1",
        "--system-ref",
        "beatlog_examples.rover:system",
    )

    assert recorded.code == 0, recorded.err
    with SessionLogReader(out) as reader:
        cycles = sum(1 for _ in reader.cycles())
        assert reader.status == LogStatus(complete=True, cycles=cycles)
        assert reader.end is not None
        assert reader.end.cycles == cycles > 0
        assert reader.end.robot_time_ns >= 500_000_000
        assert reader.header.robot_id == "rover-1"
        assert reader.header.random_seed == 11
    assert re.fullmatch(
        rf"recorded {cycles} cycles \(\d+\.\d\d s, \d+ overruns\) to {re.escape(str(out))}\n"
        rf"certified: the log replays against a fresh system \({cycles} cycles\)\n",
        recorded.out,
    ), recorded.out
    replayed = beatlog("replay", out, "--system", "beatlog_examples.rover:system")
    assert replayed.code == 0, replayed.out


def test_record_fails_a_session_that_does_not_replay_naming_the_cycle_and_the_call(
    beatlog: Beatlog, tmp_path: Path
) -> None:
    out = tmp_path / "gamble.beatlog"
    robot = "tests.systems:gambling_rover"

    recorded = beatlog("record", "--robot", robot, "-o", out, "--duration", 0.3)
    unchecked = beatlog(
        "record", "--robot", robot, "-o", tmp_path / "b.beatlog", "--duration", 0.1, "--no-certify"
    )

    assert recorded.code == 1, recorded.err
    recorded_line, certificate = recorded.out.splitlines()
    assert recorded_line.startswith("recorded ")
    assert re.match(
        r"not certified: a fresh system replays the log otherwise from cycle \d+ ", certificate
    )
    assert re.search(r"random\.choice at \S+/tests/systems\.py:\d+ in Gambler\.step", certificate)
    assert unchecked.code == 0, unchecked.err
    assert "certified" not in unchecked.out


def test_record_checks_invariants_live_and_fails_without_stopping_the_robot(
    beatlog: Beatlog, tmp_path: Path
) -> None:
    out = tmp_path / "rover.beatlog"

    recorded = beatlog(
        "record",
        "--robot",
        "beatlog_examples.rover:robot",
        "-o",
        out,
        "--duration",
        0.1,
        "--no-certify",
        "--invariants",
        "tests.systems:never_holds",
    )

    assert recorded.code == 1
    with SessionLogReader(out) as reader:
        cycles = sum(1 for _ in reader.cycles())
        assert reader.status == LogStatus(complete=True, cycles=cycles)
    assert f"{cycles} invariant violations while recording" in recorded.out
    assert "the first: cycle 0, t = " in recorded.out


def test_record_checks_the_invariants_before_recording(beatlog: Beatlog, tmp_path: Path) -> None:
    out = tmp_path / "rover.beatlog"

    run = beatlog(
        "record",
        "--robot",
        "beatlog_examples.rover:robot",
        "-o",
        out,
        "--duration",
        1,
        "--invariants",
        "tests.systems:nothing",
    )

    assert_error(run, "'tests.systems:nothing': tests.systems has no nothing")
    assert not out.exists()
