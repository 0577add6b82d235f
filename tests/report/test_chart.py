"""Timeline charts drawn with matplotlib (``beatlog plot``): behavior lanes over
robot-state signals."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.image import imread

from beatlog import replay
from beatlog.analysis.timeline import build_timeline
from beatlog.report.chart import WIDTH_PX, chart_size, draw_timeline, write_chart
from tests.conftest import RecordFn, probe_system
from tests.images import png_size
from tests.systems import moody_system, record_moody


def test_a_png_of_the_chart_size_is_written(record_probe: RecordFn, tmp_path: Path) -> None:
    timeline = build_timeline(record_probe(300), probe_system(threshold=0.6))
    png = tmp_path / "timeline.png"

    write_chart(timeline, png)

    assert png_size(png) == chart_size(timeline)
    pixels = np.rint(imread(png) * 255).astype(np.uint64)  # the PNG's 8-bit channels
    channels = pixels.shape[-1]
    # a number per color, as sorting numbers is much cheaper than sorting rows of them
    colors = np.unique(pixels.reshape(-1, channels) @ 256 ** np.arange(channels, dtype=np.uint64))
    assert len(colors) > 20  # lanes in several state colors, signals, text: not blank


def test_the_chart_is_a_row_per_lane_and_a_strip_per_signal(record_probe: RecordFn) -> None:
    log = record_probe(300)
    replayed = build_timeline(log, probe_system())
    recorded = build_timeline(log)
    one_field = build_timeline(log, fields=["distance"])

    assert chart_size(replayed)[0] == chart_size(recorded)[0] == WIDTH_PX
    row_px = (chart_size(replayed)[1] - chart_size(recorded)[1]) / 3  # a replayed row per lane
    signal_px = chart_size(recorded)[1] - chart_size(one_field)[1]
    assert 0 < row_px < signal_px


def test_the_first_divergence_is_marked_on_every_strip(record_probe: RecordFn) -> None:
    log = record_probe(300)
    divergence = replay(log, probe_system(threshold=0.6)).divergence
    assert divergence is not None

    figure = draw_timeline(build_timeline(log, probe_system(threshold=0.6), divergence=divergence))

    lanes, *signals = figure.axes[:3]
    assert (
        lanes.get_title(loc="right")
        == f"first divergence: cycle {divergence.cycle}, t = 0.660 s (state changes)"
    )
    for ax in (lanes, *signals):
        marks = [
            line
            for line in ax.get_lines()
            if np.asarray(line.get_xdata()).tolist() == [divergence.time_s] * 2
        ]
        assert len(marks) == 1
    labels = [label.get_text() for label in lanes.get_yticklabels()]
    assert labels == [
        "arbiter: recorded",
        "replayed",
        "near: recorded",
        "replayed",
        "dice: recorded",
        "replayed",
    ]


def test_a_passing_replay_has_no_divergence_mark(record_probe: RecordFn) -> None:
    figure = draw_timeline(build_timeline(record_probe(50), probe_system()))

    assert figure.axes[0].get_title(loc="right") == ""


def test_a_flag_is_drawn_as_false_and_true(tmp_path: Path) -> None:
    log = record_moody(tmp_path / "moody.beatlog")

    figure = draw_timeline(build_timeline(log, moody_system()))

    flag = figure.axes[-1]
    assert flag.get_ylabel() == "bumped"
    assert [label.get_text() for label in flag.get_yticklabels()] == ["False", "True"]
    assert flag.get_ylim() == (-0.15, 1.15)
