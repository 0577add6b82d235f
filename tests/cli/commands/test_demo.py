"""``beatlog demo``: the robot dog recorded and replayed, then its suite."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog_examples import demo
from beatlog_examples.dog import SUITE_DIR
from tests.commands import Beatlog
from tests.text import whole_lines

pytestmark = pytest.mark.usefixtures("wide_plain_console")


def test_the_demo_is_the_registered_one_run_with_the_options_given(
    beatlog: Beatlog, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """What the slow test below runs whole: the demo the examples register under the
    ``beatlog.demo`` entry points, given the duration and folder; its result is the exit
    code."""
    given: list[tuple[float, Path]] = []

    def run_demo(console: object, *, duration_s: float, out: Path) -> int:
        given.append((duration_s, out))
        return 1

    monkeypatch.setattr(demo, "run_demo", run_demo)

    run = beatlog("demo", "--duration", 0.5, "--out", tmp_path / "demo")

    assert run.code == 1
    assert given == [(0.5, tmp_path / "demo")]


@pytest.mark.slow
def test_the_demo_records_and_replays_the_dog_then_its_suite(
    beatlog: Beatlog, tmp_path: Path
) -> None:
    run = beatlog("demo", "--duration", 0.5, "--out", tmp_path / "demo")

    log = tmp_path / "demo" / "dog.beatlog"
    assert run.code == 0, run.out
    passes = [line for line in whole_lines(run.out) if line.startswith("PASS ")]
    assert len(passes) == 1, passes
    assert re.fullmatch(
        rf"PASS {re.escape(str(log))}  \d+ cycles, \d+ state changes?, \d+ outputs, "
        r"\d+ draws? checked; 0\.5 s robot time in [^;]+; log complete",
        passes[0],
    ), passes[0]
    assert f"22 DTCs recorded on the dog, replayed on all cores ({SUITE_DIR})." in whole_lines(
        run.out
    )
    counts = re.compile(r"22 passed, 0 failed in \d+\.\d\d s \(36,317 cycles\)")
    assert len([line for line in whole_lines(run.out) if counts.fullmatch(line)]) == 1
    assert f"The demo log is kept at {log}; try `beatlog show {log}`." in whole_lines(run.out)
    with SessionLogReader(log) as reader:
        cycles = sum(1 for _ in reader.cycles())
        assert reader.header.system == "beatlog_examples.dog:system"
        assert reader.status == LogStatus(complete=True, cycles=cycles)
        assert reader.end is not None
        assert reader.end.cycles == cycles > 0
        assert reader.end.robot_time_ns >= 500_000_000
