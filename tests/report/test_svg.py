"""Timeline charts as plain SVG for the HTML report: text stays text, flags read
False/True, and every state carries its class so a page colours it alike everywhere."""

from __future__ import annotations

import re
from pathlib import Path

from beatlog import replay
from beatlog.analysis.timeline import build_timeline
from beatlog.record.recorder import Recorder
from beatlog.report.svg import PALETTE, state_key, state_styles, svg_chart
from tests.conftest import PERIOD_NS, Probe, RecordFn, probe_system
from tests.systems import HOSTILE, TEX, hostile_system, moody_system, record_moody
from tests.text import svg_texts


def test_the_svg_keeps_text_as_text_and_is_the_same_every_time(record_probe: RecordFn) -> None:
    log = record_probe(300)
    divergence = replay(log, probe_system(threshold=0.6)).divergence
    assert divergence is not None
    timeline = build_timeline(log, probe_system(threshold=0.6), divergence=divergence)

    svg = svg_chart(timeline, title="avoid-pole")

    assert svg.startswith("<svg")
    assert svg.endswith("</svg>")
    texts = svg_texts(svg)
    assert texts[:3] == [
        "avoid-pole",
        "first divergence: cycle 21, t = 0.660 s (state changes)",
        "behavior states",
    ]
    for text in ("near: recorded", "replayed", "distance", "robot time (s)"):
        assert text in texts
    assert " id=" not in svg  # charts share a page without renaming anything
    assert svg_chart(timeline, title="avoid-pole") == svg


def test_a_passing_replay_has_no_divergence_mark(record_probe: RecordFn) -> None:
    svg = svg_chart(build_timeline(record_probe(50), probe_system()))

    assert svg_texts(svg) == [
        "probe.beatlog: 50 cycles",
        "behavior states",
        *("arbiter: recorded", "dice", "near", "replayed", "dice", "near"),
        *("near: recorded", "far", "near", "replayed", "far", "near"),
        *("dice: recorded", *["odd", "even"] * 3, "replayed", *["odd", "even"] * 3),
        *("distance", "0.5", "1"),
        *("reading", "-1", "-0.5", "0", "0.5", "1"),
        *("0", "0.2", "0.4", "0.6", "0.8", "1", "1.2", "1.4", "robot time (s)"),
        *("idle", "dice", "near", "far", "even", "odd"),
    ]


def test_names_and_states_are_text_never_markup(tmp_path: Path) -> None:
    log = tmp_path / "hostile.beatlog"
    with Recorder(log, hostile_system(), software="t") as recorder:
        for t in range(40):
            recorder.step(PERIOD_NS, Probe(distance=abs(20 - t) / 20))

    svg = svg_chart(build_timeline(log, hostile_system()), title=HOSTILE)

    assert "<script" not in svg
    assert "<b>" not in svg
    near = "<b>near</b>"
    assert svg_texts(svg) == [  # names and states drawn as typed, TeX included
        HOSTILE,
        "behavior states",
        *("arbiter: recorded", "idle", "replayed", "idle"),
        *(f"{HOSTILE}: recorded", TEX, near, TEX, "replayed", TEX, near, TEX),
        *("distance", "0", "0.5", "1"),
        *("reading", "-1", "-0.5", "0", "0.5", "1"),
        *("0", "0.2", "0.4", "0.6", "0.8", "1", "robot time (s)"),
        *("idle", TEX, near),
    ]


def test_a_flag_reads_false_and_true_on_its_axis(tmp_path: Path) -> None:
    svg = svg_chart(build_timeline(record_moody(tmp_path / "moody.beatlog"), moody_system()))

    strips = svg.split(">level</text>")[1].split(">bumped</text>")
    assert ">False</text>" not in strips[0]  # a number gets numbers
    assert re.findall(r">(False|True)</text>", strips[1]) == ["False", "True"]


def test_every_bar_of_a_state_carries_its_class(record_probe: RecordFn) -> None:
    timeline = build_timeline(record_probe(300), probe_system())

    svg = svg_chart(timeline)

    states = timeline.states()
    assert {"far", "near"} <= set(states)
    classes = set(re.findall(r'class="(s-[0-9a-f]{8})"', svg))
    assert classes == {state_key(label) for label in states}


def test_a_page_gives_states_the_palette_in_order_of_first_appearance() -> None:
    css = state_styles(["near", "far", "near", "odd"])

    assert css == (
        f".{state_key('near')}{{fill:{PALETTE[0]}}}"
        f".{state_key('far')}{{fill:{PALETTE[1]}}}"
        f".{state_key('odd')}{{fill:{PALETTE[2]}}}"
    )
