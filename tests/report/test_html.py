"""The HTML report: one self-contained page, a summary, then each DTC with its timeline.

The last test opens the page in headless Chromium and checks the charts are drawn.
"""

from __future__ import annotations

import os
import re
import shutil
from io import BytesIO
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest
from matplotlib.image import imread

from beatlog.record.recorder import Recorder
from beatlog.report.html import write_html
from beatlog.suite.parallel import run_suite
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog_examples.rover import record_lockstep
from tests.conftest import PERIOD_NS, Probe, RecordFn
from tests.perceptions import CHANGED, record_with_samples
from tests.specs import written_dtc
from tests.systems import HOSTILE, hostile_system
from tests.text import svg_texts, whole_lines

ROVER = "beatlog_examples.rover:system"
ROVER_CHANGED = "beatlog_examples.rover:changed_system"
HOSTILE_SYSTEM = "tests.systems:hostile_system"
IMG = "<img src=x onerror=alert(1)>"


class Report(NamedTuple):
    outcomes: list[SpecOutcome]
    page: str
    path: Path


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> Report:
    """A suite of four DTCs (pass, fail, error, hostile names), run once for the module."""
    folder = tmp_path_factory.mktemp("html")
    rover = folder / "rover.beatlog"
    record_lockstep(rover, duration_s=10.0, seed=2)  # meets an obstacle within its first second
    hostile = folder / "hostile.beatlog"
    with Recorder(hostile, hostile_system(), software="t") as recorder:
        for t in range(40):
            recorder.step(PERIOD_NS, Probe(distance=abs(20 - t) / 20))
    specs = [
        written_dtc(folder, "wander", rover, ROVER),
        written_dtc(
            folder, "avoid-earlier", rover, ROVER_CHANGED, purpose="Avoid turns 10 cm earlier."
        ),
        written_dtc(folder, "lost", folder / "lost.beatlog", ROVER),
        written_dtc(
            folder,
            "hostile",
            hostile,
            HOSTILE_SYSTEM,
            name=HOSTILE,
            purpose=IMG,
            procedure=[IMG, "</dd></dl><h1>injected</h1>"],
            tags=["<i>"],
        ),
    ]
    outcomes = run_suite(specs, timelines=True)
    path = folder / "report.html"
    write_html(outcomes, path)
    return Report(outcomes, path.read_text(encoding="utf-8"), path)


def section(page: str, index: int) -> str:
    """The markup of the ``index``-th DTC's section (from 1)."""
    start = page.index(f'id="dtc-{index}"')
    return page[start : page.index("</section>", start)]


def test_the_report_opens_with_the_counts_and_a_row_per_dtc(report: Report) -> None:
    assert [o.verdict for o in report.outcomes] == [
        Verdict.PASSED,
        Verdict.FAILED,
        Verdict.ERROR,
        Verdict.PASSED,
    ]
    page = report.page
    assert page.startswith("<!DOCTYPE html>")
    assert "<title>beatlog DTC report: 2 passed, 1 failed, 1 error</title>" in whole_lines(page)
    summary = page[page.index('<table class="suite">') : page.index("</table>")]
    assert re.findall(r'<a href="#(dtc-\d)">([^<]*)</a>', summary) == [
        ("dtc-1", "wander"),
        ("dtc-2", "avoid-earlier"),
        ("dtc-3", "lost"),
        ("dtc-4", "&lt;script&gt;alert(&#x27;x&#x27;)&lt;/script&gt;"),
    ]
    failed = report.outcomes[1].result
    assert failed is not None
    assert failed.divergence is not None
    lost = report.path.parent / "lost.beatlog"
    assert re.findall(r"<td>([^<]*)</td></tr>", summary) == [
        "",
        f"cycle {failed.divergence.cycle}, t = {failed.divergence.time_s:.3f} s, state changes",
        f"{lost}: no such file (a spec&#x27;s log is relative to its folder)",
        "",
    ]


def test_a_failure_reads_in_one_screen_then_shows_a_close_up_and_the_whole_session(
    report: Report,
) -> None:
    outcome = report.outcomes[1]
    assert outcome.result is not None
    divergence = outcome.result.divergence
    assert divergence is not None
    failed = section(report.page, 2)

    headline = (
        f"First divergence: cycle {divergence.cycle}, t = {divergence.time_s:.3f} s "
        f"— {divergence.kind}"
    )
    rerun = f"Rerun just this DTC: <code>beatlog test {outcome.spec.path}</code>"
    order = [
        '<section class="dtc failed"',
        '<span class="verdict">failed</span> avoid-earlier',
        "Avoid turns 10 cm earlier.",
        headline,
        divergence.message,
        "arbiter: &#x27;wander&#x27; -&gt; &#x27;avoid&#x27;",
        rerun,
        "avoid-earlier: close-up of the first divergence",
        "avoid-earlier: the whole session",
        "<caption>state changes around it</caption>",
        "<caption>robot state RS_t</caption>",
    ]
    positions = [failed.find(text) if text != order[0] else 0 for text in order]
    assert -1 not in positions, [text for text, at in zip(order, positions, strict=True) if at < 0]
    assert positions == sorted(positions)
    assert failed.count("<svg") == 2
    assert failed.count(f"first divergence: cycle {divergence.cycle}") == 2


def test_a_pass_gets_its_timeline_and_no_divergence(report: Report) -> None:
    passed = section(report.page, 1)

    (chart,) = svg_charts(passed)
    assert "First divergence" not in passed
    texts = svg_texts(chart)
    assert texts[:3] == [
        "wander: the whole session, 334 cycles, 10.0 s",
        "behavior states",
        "arbiter: recorded",
    ]
    assert "wander: recorded" in texts


def svg_charts(markup: str) -> list[str]:
    """The SVG charts drawn in ``markup``, in order."""
    return re.findall(r"<svg.*?</svg>", markup, flags=re.DOTALL)


def legend(chart: str) -> dict[str, str]:
    """A chart's legend: each state's label and the class its swatch is coloured by."""
    return {
        label: key
        for key, label in re.findall(
            r'<rect [^>]*class="(s-[0-9a-f]+)"[^>]*/><text [^>]*>([^<]*)</text>', chart
        )
    }


def test_a_state_has_one_colour_in_every_chart_of_the_page(report: Report) -> None:
    page = report.page
    styles = page[page.index("<style>") : page.index("</style>")]
    fills = dict(re.findall(r"\.(s-[0-9a-f]+)\{fill:(#[0-9a-f]{6})\}", styles))
    drawn = svg_charts(page)
    close_up, whole = (legend(chart) for chart in drawn[1:3])  # avoid-earlier's two

    colours = [{label: fills[key] for label, key in chart.items()} for chart in map(legend, drawn)]

    assert {"wander", "avoid", "clear"} <= set(close_up)
    assert {label: whole[label] for label in close_up} == close_up
    for label, colour in colours[1].items():
        assert colours[2][label] == colour
        assert colours[0].get(label, colour) == colour
    assert len(set(fills.values())) == len(fills)  # different states, different colours


def test_a_perception_divergence_shows_the_fields_rebuilt_and_the_samples(
    tmp_path: Path,
) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")
    spec = written_dtc(tmp_path, "sensors", log, "tests.conftest:probe_system", perception=CHANGED)
    path = tmp_path / "report.html"
    write_html(run_suite([spec]), path)
    sensors = section(path.read_text(encoding="utf-8"), 1)

    assert (
        "<table><caption>robot state from the samples</caption>"
        "<tr><th>recorded</th><th>replayed</th></tr>"
        '<tr class="differs"><td>distance = 1.0</td><td>distance = 1.1</td></tr></table>'
    ) in whole_lines(sensors)
    assert '<p class="samples">samples: range [1.0, 1]</p>' in whole_lines(sensors)


def test_an_error_says_why_and_draws_nothing(report: Report) -> None:
    error = section(report.page, 3)

    lost = report.path.parent / "lost.beatlog"
    assert (
        f'<p class="error">{lost}: no such file (a spec&#x27;s log is relative to its folder)</p>'
        in whole_lines(error)
    )
    assert "<svg" not in error


def test_user_data_is_text_everywhere_never_markup(report: Report) -> None:
    page = report.page

    assert "<script" not in page
    assert "<img" not in page
    assert "<i>" not in page
    assert "<h1>injected" not in page
    assert page.count("<h1>") == 1
    hostile = section(page, 4)
    assert (
        '<h2><span class="verdict">passed</span> '
        "&lt;script&gt;alert(&#x27;x&#x27;)&lt;/script&gt;</h2>" in whole_lines(hostile)
    )
    assert '<p class="purpose">&lt;img src=x onerror=alert(1)&gt;</p>' in whole_lines(hostile)
    (chart,) = svg_charts(hostile)
    assert "<b>near</b>" in svg_texts(chart)  # a state, drawn in the chart as text


def test_the_page_needs_nothing_but_itself(report: Report) -> None:
    page = report.page

    assert " src=" not in page.replace("&lt;img src=", "")
    assert "<link" not in page
    assert "@import" not in page
    links = re.findall(r'href="([^"]*)"', page)  # the summary's and the charts' own markers
    assert links[:4] == [f"#dtc-{n}" for n in range(1, 5)]
    assert all(link.startswith("#") for link in links)
    ids = re.findall(r'\bid="([^"]+)"', page)
    assert len(ids) == len(set(ids))  # charts on one page never share an id
    used = re.findall(r'(?:url\(#|href="#)([^")]+)', page)
    assert set(used) <= set(ids)


def test_an_unwritable_report_is_an_os_error(report: Report, tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        write_html(report.outcomes[2:3], tmp_path / "no" / "such" / "folder" / "report.html")


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_chromium_draws_every_chart(report: Report) -> None:
    """Open the page in headless Chromium: every chart has its size, lanes and colors."""
    if CHROMIUM is None or CHROMEDRIVER is None:
        reason = "needs chromium and chromedriver (apt-get install chromium chromium-driver)"
        if os.environ.get("BEATLOG_REQUIRE_BROWSER") == "1":
            pytest.fail(f"BEATLOG_REQUIRE_BROWSER=1 but {reason}")
        pytest.skip(reason)
    from selenium import webdriver  # noqa: PLC0415 - only this test needs a browser
    from selenium.webdriver.chrome.service import Service  # noqa: PLC0415
    from selenium.webdriver.common.by import By  # noqa: PLC0415

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1300,900"):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(options=options, service=Service(executable_path=CHROMEDRIVER))
    try:
        driver.get(report.path.as_uri())
        charts = driver.find_elements(By.CSS_SELECTOR, "figure.timeline svg")
        drawn = [
            driver.execute_script(
                "const box = arguments[0].getBoundingClientRect();"
                "return {width: box.width, height: box.height,"
                " bars: arguments[0].querySelectorAll('rect').length,"
                " texts: [...arguments[0].querySelectorAll('text')].map(t => t.textContent)};",
                chart,
            )
            for chart in charts
        ]
        driver.execute_script("arguments[0].scrollIntoView()", charts[1])
        pixels = imread(BytesIO(charts[1].screenshot_as_png))
        console = driver.get_log("browser")  # type: ignore[no-untyped-call]
        errors = [entry for entry in console if entry["level"] == "SEVERE"]
    finally:
        driver.quit()

    assert len(drawn) == 4  # wander, avoid-earlier's close-up and whole session, hostile
    for chart in drawn:
        assert chart["width"] > 600
        assert chart["height"] > 200
        assert chart["bars"] > 10
    assert [chart["texts"] for chart in drawn] == list(map(svg_texts, svg_charts(report.page)))
    assert any(text.startswith("first divergence: cycle") for text in drawn[1]["texts"])
    colors = np.unique(pixels.reshape(-1, pixels.shape[-1]), axis=0)
    assert len(colors) > 20
    assert errors == []


def test_an_invariant_divergence_shows_the_behavior_states(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    spec = written_dtc(
        tmp_path,
        "close",
        record_probe(300),
        "tests.conftest:probe_system",
        invariants=["tests.systems:never_close"],
    )
    path = tmp_path / "report.html"
    write_html(run_suite([spec]), path)
    close = section(path.read_text(encoding="utf-8"), 1)

    assert "invariant never_close does not hold: 0.3 m from the pole" in close
    assert "<caption>behavior states after the update</caption>" in close
    assert '<tr><td>near</td><td><span class="value">&#x27;near&#x27;</span></td></tr>' in close
