"""Timeline charts: behavior lanes over robot-state signals, as PNG and as inline SVG."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from beatlog import replay
from beatlog.analysis.timeline import build_timeline
from beatlog.record.recorder import Recorder
from beatlog.report.chart import WIDTH_PX, chart_size, draw_timeline, svg_markup, write_chart
from tests.conftest import PERIOD_NS, Probe, RecordFn, probe_system
from tests.images import png_size
from tests.systems import HOSTILE, TEX, hostile_system


@pytest.fixture
def hostile_log(tmp_path: Path) -> Path:
    log = tmp_path / "hostile.beatlog"
    with Recorder(log, hostile_system(), software="t") as recorder:
        for t in range(40):
            recorder.step(PERIOD_NS, Probe(distance=abs(20 - t) / 20))
    return log


def test_a_png_of_the_chart_size_is_written(record_probe: RecordFn, tmp_path: Path) -> None:
    timeline = build_timeline(record_probe(300), probe_system(threshold=0.6))
    png = tmp_path / "timeline.png"

    write_chart(timeline, png)

    assert png_size(png) == chart_size(timeline)
    pixels = imread(png)
    colors = np.unique(pixels.reshape(-1, pixels.shape[-1]), axis=0)
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
    assert f"first divergence: cycle {divergence.cycle}, t = " in lanes.get_title(loc="right")
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


def test_the_svg_keeps_text_as_text_and_is_the_same_every_time(record_probe: RecordFn) -> None:
    log = record_probe(300)
    divergence = replay(log, probe_system(threshold=0.6)).divergence
    timeline = build_timeline(log, probe_system(threshold=0.6), divergence=divergence)

    svg = svg_markup(timeline, title="avoid-pole")

    assert svg.startswith("<svg")
    assert svg.rstrip().endswith("</svg>")
    for text in ("avoid-pole", "near: recorded", "replayed", "first divergence: cycle"):
        assert text in svg
    assert svg_markup(timeline, title="avoid-pole") == svg


def test_names_and_states_are_text_never_markup_or_tex(hostile_log: Path) -> None:
    svg = svg_markup(build_timeline(hostile_log, hostile_system()), title=HOSTILE)

    assert "<script" not in svg
    assert "<b>" not in svg
    assert "&lt;script&gt;alert('x')&lt;/script&gt;: recorded" in svg
    assert "&lt;b&gt;near&lt;/b&gt;" in svg
    assert TEX in svg  # drawn as typed, not typeset
