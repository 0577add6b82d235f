"""DTC specs and suites: ``*.dtc.toml`` files, the parallel runner, JUnit output and the
re-baselining workflow (update, review, approve) with its CI rule."""

from beatlog.suite.junit import write_junit
from beatlog.suite.maintenance import Decision, approve, decide, update_baselines
from beatlog.suite.policy import UpdateMode
from beatlog.suite.runner import SpecOutcome, Verdict, run_spec, run_suite
from beatlog.suite.spec import SPEC_SUFFIX, DtcSpec, discover_specs, load_spec, select_specs

__all__ = [
    "SPEC_SUFFIX",
    "Decision",
    "DtcSpec",
    "SpecOutcome",
    "UpdateMode",
    "Verdict",
    "approve",
    "decide",
    "discover_specs",
    "load_spec",
    "run_spec",
    "run_suite",
    "select_specs",
    "update_baselines",
    "write_junit",
]
