"""The hash-seed bench: what it compares between runs, and that a change is listed."""

from __future__ import annotations

from pathlib import Path

from bench_hashseed import Run, changes, normal_junit, seeds

JUNIT = """<?xml version="1.0" encoding="utf-8"?>
<testsuites><testsuite name="beatlog" tests="2" time="{time}" timestamp="{time}" hostname="h">
<testcase classname="dtc" name="approach" time="{time}"/>
<testcase classname="dtc" name="idle" time="0.1">{verdict}</testcase>
</testsuite></testsuites>
"""


def _junit(tmp_path: Path, name: str, time: str, verdict: str = "") -> Path:
    path = tmp_path / name
    path.write_text(JUNIT.format(time=time, verdict=verdict), encoding="utf-8")
    return path


def test_times_host_and_timestamp_are_left_out_and_verdicts_read(tmp_path: Path) -> None:
    first, first_verdicts = normal_junit(_junit(tmp_path, "a.xml", "1.5"))
    again, _ = normal_junit(_junit(tmp_path, "b.xml", "2.7"))
    assert first == again
    assert first_verdicts == {"approach": "passed", "idle": "passed"}
    _, failed = normal_junit(_junit(tmp_path, "c.xml", "1.5", '<failure message="x"/>'))
    assert failed == {"approach": "passed", "idle": "failure"}


def test_a_changed_verdict_exit_code_and_report_are_each_listed() -> None:
    first = Run(1, 0, {"approach": "passed", "idle": "passed"}, "<junit/>", "{}")
    assert changes(first, first._replace(seed=2)) == []
    changed = Run(2, 1, {"approach": "passed", "idle": "failure"}, "<junit2/>", "{}")
    assert changes(first, changed) == [
        "exit code 0 -> 1",
        "idle: passed -> failure",
        "the JUnit report differs",
    ]
    assert changes(first, first._replace(coverage="{ }")) == ["the coverage JSON differs"]


def test_the_seeds_are_distinct_and_never_zero() -> None:
    chosen = seeds(100)
    assert len(set(chosen)) == 100
    assert all(0 < seed < 2**32 for seed in chosen)
