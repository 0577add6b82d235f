"""JUnit XML for CI systems, written whole or not at all: one testcase per DTC (named
by its id where another DTC of the run has its name), failures with the first
divergence, errors with the traceback of the user's code when it raised. A DTC that ran
carries what its replay checked as properties (``beatlog_cycles``,
``beatlog_state_changes``..., as the pytest plugin names them); one whose determinism
audit found something gets a failure typed ``determinism audit``; one run again because
its worker died gets a ``flakyError`` per retry, as Maven Surefire writes reruns.
"""

from __future__ import annotations

import posixpath
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from pathlib import Path

from beatlog.log.files import replacing
from beatlog.suite.runner import SpecOutcome, Verdict

__all__ = ["write_junit"]


def write_junit(
    path: Path, outcomes: Sequence[SpecOutcome], *, describe: Callable[[SpecOutcome], str]
) -> None:
    """Write ``outcomes`` as a JUnit testsuite; ``describe`` gives a failure's text."""
    suite = ET.Element(
        "testsuite",
        name="beatlog",
        tests=str(len(outcomes)),
        failures=str(sum(o.verdict is Verdict.FAILED or o.audit_findings > 0 for o in outcomes)),
        errors=str(sum(o.verdict is Verdict.ERROR for o in outcomes)),
        time=f"{sum(o.wall_time_s for o in outcomes):.3f}",
    )
    for outcome in outcomes:
        case = ET.SubElement(
            suite,
            "testcase",
            classname=posixpath.dirname(outcome.spec.origin) or ".",
            name=outcome.spec.label,
            file=outcome.spec.origin,
            time=f"{outcome.wall_time_s:.3f}",
        )
        if outcome.result is not None:
            properties = ET.SubElement(case, "properties")
            for name, count in outcome.result.counts.items():
                ET.SubElement(properties, "property", name=f"beatlog_{name}", value=str(count))
        if outcome.verdict is Verdict.FAILED:
            divergence = outcome.result.divergence if outcome.result else None
            message = divergence.message if divergence else "diverged"
            ET.SubElement(case, "failure", message=message).text = describe(outcome)
        elif outcome.verdict is Verdict.ERROR:
            error = ET.SubElement(case, "error", message=outcome.error or "error")
            error.text = outcome.error_traceback or outcome.error
        for _ in range(outcome.retries):
            ET.SubElement(
                case, "flakyError", type="worker lost", message="the worker replaying it died"
            )
        audit = outcome.audit
        if audit is not None and not audit.ok:
            message = f"determinism audit: {audit.summary()}"
            failure = ET.SubElement(case, "failure", type="determinism audit", message=message)
            failure.text = "\n".join(audit.lines())
    path.parent.mkdir(parents=True, exist_ok=True)  # as pytest's --junit-xml does
    with replacing(path) as file:
        ET.ElementTree(suite).write(file, encoding="utf-8", xml_declaration=True)
