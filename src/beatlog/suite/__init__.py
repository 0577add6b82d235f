"""DTC specs and suites: ``*.dtc.toml`` files, the parallel runner and JUnit output."""

from beatlog.suite.junit import write_junit
from beatlog.suite.runner import SpecOutcome, Verdict, run_spec, run_suite
from beatlog.suite.spec import SPEC_SUFFIX, DtcSpec, discover_specs, load_spec, select_specs

__all__ = [
    "SPEC_SUFFIX",
    "DtcSpec",
    "SpecOutcome",
    "Verdict",
    "discover_specs",
    "load_spec",
    "run_spec",
    "run_suite",
    "select_specs",
    "write_junit",
]
