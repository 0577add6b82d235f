"""A suite session's options: one typed object that refuses options that do not go
together when it is made, as ``beatlog test`` names them."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.baseline.policy import UpdateMode
from beatlog.errors import OptionError
from beatlog.suite.options import SuiteOptions
from tests.specs import PROBE


@pytest.mark.parametrize(
    ("given", "problem"),
    [
        ({"system": PROBE}, "--system and --perception go with --logs: a spec names its own"),
        (
            {"perception": "tests.x:step"},
            "--system and --perception go with --logs: a spec names its own",
        ),
        ({"logs": "*.beatlog"}, "--logs needs --system MODULE:FACTORY to replay the logs against"),
        (
            {"logs": "*.beatlog", "system": PROBE, "paths": (Path("specs"),)},
            "give DTC specs or --logs, not both",
        ),
        (
            {"logs": "*.beatlog", "system": PROBE, "update": UpdateMode.NEW},
            "--update writes the baselines of specs; --logs runs have none",
        ),
        (
            {"logs": "*.beatlog", "system": PROBE, "last_failed": True},
            "--lf reruns the specs that failed; --logs runs are not remembered",
        ),
    ],
    ids=[
        "system-without-logs",
        "perception-without-logs",
        "logs-alone",
        "logs-and-specs",
        "update",
        "last-failed",
    ],
)
def test_options_that_do_not_go_together_are_refused(
    given: dict[str, object], problem: str
) -> None:
    with pytest.raises(OptionError) as refused:
        SuiteOptions(**given)  # type: ignore[arg-type]

    assert str(refused.value) == problem


def test_a_fleet_run_takes_its_logs_and_system() -> None:
    options = SuiteOptions(logs="fleet/*.beatlog", system=PROBE)

    assert (options.logs, options.system, options.paths) == ("fleet/*.beatlog", PROBE, (Path(),))


def test_the_reports_are_those_asked_for(tmp_path: Path) -> None:
    junit, html = tmp_path / "junit.xml", tmp_path / "report.html"

    assert SuiteOptions().reports == ()
    assert SuiteOptions(html=html, junit_xml=junit).reports == (junit, html)


@pytest.mark.parametrize(
    ("given", "breaking"),
    [({}, False), ({"break_at": 0}, True), ({"break_on_divergence": True}, True)],
)
def test_a_session_breaks_with_either_break_point(given: dict[str, object], breaking: bool) -> None:
    assert SuiteOptions(**given).breaking is breaking  # type: ignore[arg-type]
