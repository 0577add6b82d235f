"""Damaged, foreign and hostile logs through the CLI: one line naming the file, exit 2."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from beatlog.log.format import FORMAT_VERSION
from tests.commands import Beatlog
from tests.conftest import RecordFn
from tests.crafting import (
    STANDARD_CHANNELS,
    Channel,
    chunks,
    craft_log,
    cycle_messages,
    deeply_nested,
    drop_chunk,
    end_message,
    header_message,
    standard_messages,
)
from tests.factories import PROBE_CYCLE_DAMAGE, rewrite_cycle, with_damaged_index
from tests.specs import GAUGE, PROBE, write_spec


def dropped_chunk(path: Path) -> Path:
    data = craft_log(path, standard_messages(60)).read_bytes()
    path.write_bytes(drop_chunk(data, chunks(data)[2]))
    return path


def foreign_cycles_topic(path: Path) -> Path:
    channels = (*STANDARD_CHANNELS, Channel("/beatlog/cycles2", schema="beatlog.CycleBatch"))
    return craft_log(path, standard_messages(20), channels=channels)


def end_count_mismatch(path: Path) -> Path:
    return craft_log(path, [*standard_messages(20)[:-1], end_message(999)])


def deep_robot_id(path: Path) -> Path:
    return craft_log(path, [header_message(robot_id=deeply_nested()), *cycle_messages(5)])


def huge_robot_id(path: Path) -> Path:
    return craft_log(path, [header_message(robot_id="r" * 50_000_000), *cycle_messages(5)])


def many_behaviors(path: Path) -> Path:
    names = [f"behavior-{i}" for i in range(200_000)]
    return craft_log(path, [header_message(behaviors=names), *cycle_messages(5)])


HOSTILE: dict[str, tuple[Callable[[Path], Path], str]] = {
    "dropped-chunk": (
        dropped_chunk,
        "cycles out of order: a batch starts at cycle 20 where cycle 10 is next "
        "(a chunk missing, repeated or moved)",
    ),
    "foreign-topic": (
        foreign_cycles_topic,
        "a foreign channel '/beatlog/cycles2' in a session log",
    ),
    "end-count": (
        end_count_mismatch,
        "the end record counts 999 cycles and 29970000000 ns of robot time, "
        "but the log holds 20 cycles and 600000000 ns",
    ),
    "deep-nesting": (
        deep_robot_id,
        "damaged session header: maximum recursion depth exceeded while deserializing an object",
    ),
    "huge-robot-id": (
        huge_robot_id,
        "damaged record at byte 46: a chunk claims 50000595 bytes uncompressed",
    ),
    "many-behaviors": (
        many_behaviors,
        "damaged session header: 3089158 bytes, more than the 1048576 a header may hold",
    ),
}


@pytest.mark.parametrize("name", HOSTILE)
@pytest.mark.parametrize("command", ["show", "replay"])
def test_show_and_replay_refuse_a_hostile_log_in_one_line(
    tmp_path: Path, beatlog: Beatlog, name: str, command: str
) -> None:
    build, problem = HOSTILE[name]
    log = build(tmp_path / f"{name}.beatlog")
    extra = ["--system", GAUGE, "--allow-truncated"] if command == "replay" else []
    code, out, err = beatlog(command, log, *extra)
    assert code == 2
    assert out == ""
    assert err == f"beatlog: error: {log}: {problem}\n"


@pytest.mark.parametrize("name", HOSTILE)
def test_beatlog_test_reports_a_hostile_log_as_an_error(
    tmp_path: Path, beatlog: Beatlog, name: str
) -> None:
    build, problem = HOSTILE[name]
    log = build(tmp_path / f"{name}.beatlog")
    spec = write_spec(tmp_path, "hostile", log, GAUGE)
    code, _out, err = beatlog("test", tmp_path)
    assert code == 2
    assert err == f"beatlog: error: hostile ({spec}): {log}: {problem}\n"


def test_a_spec_whose_log_is_a_fifo_is_an_error_not_a_hang(tmp_path: Path) -> None:
    fifo = tmp_path / "session.beatlog"
    os.mkfifo(fifo)
    write_spec(tmp_path, "hostile", fifo, PROBE)
    done = subprocess.run(
        [sys.executable, "-m", "beatlog.cli.main", "test", "-j", "1", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 2
    assert done.stderr == (
        f"beatlog: error: hostile ({tmp_path / 'hostile.dtc.toml'}): {fifo}: is not a regular "
        "file (a FIFO, socket or device)\n"
    )
    assert "Traceback" not in done.stderr


def test_show_says_which_format_version_a_log_is(tmp_path: Path, beatlog: Beatlog) -> None:
    current = craft_log(tmp_path / "current.beatlog", standard_messages(5))
    code, out, _ = beatlog("show", current)
    assert code == 0
    assert ["format", "version", str(FORMAT_VERSION)] in [line.split() for line in out.splitlines()]


def test_show_says_which_python_a_log_was_recorded_under(
    tmp_path: Path, beatlog: Beatlog, record_probe: RecordFn
) -> None:
    older = craft_log(tmp_path / "older.beatlog", standard_messages(5))

    recorded = [line.split() for line in beatlog("show", record_probe(5)).out.splitlines()]
    unknown = [line.split() for line in beatlog("show", older).out.splitlines()]

    assert ["under", "Python", platform.python_version()] in [line[-3:] for line in recorded]
    assert not any("Python" in line for line in unknown)


@pytest.mark.parametrize("name", PROBE_CYCLE_DAMAGE)
def test_a_cycle_that_does_not_hold_what_the_header_declares_is_a_damaged_log(
    tmp_path: Path, beatlog: Beatlog, record_probe: RecordFn, name: str
) -> None:
    damage = PROBE_CYCLE_DAMAGE[name]
    log = rewrite_cycle(record_probe(60), tmp_path / f"{name}.beatlog", damage.cycle, damage.edit)

    run = beatlog("replay", log, "--system", PROBE)

    assert run == (2, "", f"beatlog: error: {log}: {damage.problem}\n")


def test_another_robots_log_is_bad_input_naming_what_does_not_fit(
    beatlog: Beatlog, record_probe: RecordFn
) -> None:
    log = record_probe(20)

    run = beatlog("replay", log, "--system", "tests.systems:rover_system")

    assert run == (
        2,
        "",
        f"beatlog: error: {log}: recorded with robot state tests.conftest.Probe, which does "
        "not fit the system's tests.systems.Rover: Probe is not Rover (a robot state type "
        "renamed since keeps exactly its fields)\n",
    )


def test_replay_refuses_a_log_whose_index_is_damaged_though_its_data_is_intact(
    tmp_path: Path, beatlog: Beatlog, record_probe: RecordFn
) -> None:
    log = with_damaged_index(record_probe(60), tmp_path / "index.beatlog")

    run = beatlog("replay", log, "--system", PROBE)

    assert run == (
        2,
        "",
        f"beatlog: error: {log}: index damaged, data intact: the summary does not match its "
        "CRC in the footer\n",
    )
