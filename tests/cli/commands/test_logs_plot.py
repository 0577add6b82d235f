"""``beatlog plot``: a PNG, SVG or PDF timeline of a session; one clean line per bad input."""

from __future__ import annotations

import functools
import re
from collections.abc import Callable
from pathlib import Path

import pytest

from beatlog import replay
from tests.commands import (
    Beatlog,
    Run,
    assert_error,
    assert_error_matching,
    cannot_import,
    hide_matplotlib,
)
from tests.conftest import RecordFn, probe_system_changed
from tests.images import png_size
from tests.specs import CHANGED, PROBE

Plot = Callable[..., Run]


@pytest.fixture
def plot(beatlog: Beatlog) -> Plot:
    """``beatlog plot ARGS``."""
    return functools.partial(beatlog, "plot")


@pytest.fixture
def log(record_probe: RecordFn) -> Path:
    return record_probe(300)


def test_plot_draws_the_recording_without_running_any_code(
    plot: Plot, log: Path, tmp_path: Path
) -> None:
    png = tmp_path / "session.png"

    run = plot(log, "-o", png)

    assert run.code == 0
    assert run.err == ""
    assert run.out == f"drew 300 cycles of {log} to {png}\n"
    width, height = png_size(png)
    assert (width, height) == (1200, 3 * 22 + 2 * 100 + 170)  # 3 lanes, 2 numeric fields


def test_plot_with_a_system_also_draws_the_replay_and_names_the_first_divergence(
    plot: Plot, log: Path, tmp_path: Path
) -> None:
    png = tmp_path / "changed.png"
    divergence = replay(log, probe_system_changed()).divergence
    assert divergence is not None

    run = plot(log, "-o", png, "--system", CHANGED, "--field", "distance")

    assert run.code == 0
    assert run.out == (
        f"drew 300 cycles of {log} to {png}; "
        f"first divergence at cycle {divergence.cycle} (state changes)\n"
    )
    assert png_size(png) == (1200, 6 * 22 + 1 * 100 + 170)  # recorded and replayed rows


def test_plot_of_a_passing_replay_names_no_divergence(
    plot: Plot, log: Path, tmp_path: Path
) -> None:
    chart = tmp_path / "pass.png"
    run = plot(log, "-o", chart, "--system", PROBE)

    assert (run.code, run.out) == (0, f"drew 300 cycles of {log} to {chart}\n")


# bad input: exit 2 and one line on stderr


@pytest.mark.parametrize(
    ("suffix", "magic"), [(".svg", b"<?xml"), (".pdf", b"%PDF-"), (".PNG", b"\x89PNG")]
)
@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_the_suffix_picks_the_format(
    plot: Plot, log: Path, tmp_path: Path, suffix: str, magic: bytes
) -> None:
    chart = tmp_path / f"session{suffix}"

    run = plot(log, "-o", chart)

    assert run.code == 0, run.err
    assert chart.read_bytes().startswith(magic)


@pytest.mark.parametrize(("name", "given"), [("y.txt", "suffix .txt"), ("y", "no suffix")])
def test_an_unknown_suffix_is_refused_in_one_line(
    plot: Plot, log: Path, tmp_path: Path, name: str, given: str
) -> None:
    chart = tmp_path / name

    run = plot(log, "-o", chart, "--system", PROBE)

    assert_error(run, f"{chart}: a chart is written as .png, .svg, .pdf, not {given}")
    assert not chart.exists()


def test_a_field_the_robot_state_lacks_is_one_line(plot: Plot, log: Path, tmp_path: Path) -> None:
    png = tmp_path / "x.png"

    run = plot(log, "-o", png, "--field", "speed")

    assert_error(
        run, f"{log}: the robot state has no field 'speed' (numeric fields: distance, reading)"
    )
    assert not png.exists()


def test_an_unwritable_picture_is_one_line_naming_it(plot: Plot, log: Path, tmp_path: Path) -> None:
    png = tmp_path / "no" / "such" / "folder" / "x.png"

    run = plot(log, "-o", png)

    assert_error(run, f"{png}: cannot write: No such file or directory")


def test_a_missing_log_is_one_line(plot: Plot, tmp_path: Path) -> None:
    run = plot(tmp_path / "lost.beatlog", "-o", tmp_path / "x.png")

    assert_error(run, f"{tmp_path / 'lost.beatlog'}: no such file")


def test_a_bad_system_is_one_line(plot: Plot, log: Path, tmp_path: Path) -> None:
    run = plot(log, "-o", tmp_path / "x.png", "--system", "tests.nowhere:system")

    assert_error_matching(
        run, re.escape("'tests.nowhere:system': ") + cannot_import("tests.nowhere")
    )


def test_the_output_is_required(plot: Plot, log: Path) -> None:
    run = plot(log)

    assert_error(
        run, "the following arguments are required: -o/--output (see 'beatlog plot --help')"
    )


def test_without_matplotlib_plot_says_which_extra_to_install(
    plot: Plot, log: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    hide_matplotlib(monkeypatch)

    run = plot(log, "-o", tmp_path / "x.png")

    assert_error(run, 'plot needs matplotlib (pip install "beatlog[plot]")')
