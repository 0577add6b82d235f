"""DTC specs and suites: ``*.dtc.toml`` files, fleet runs of logs without specs, the
parallel runner and its Dask executor, shards for a CI matrix, JUnit output and the
re-baselining workflow (update, review, approve) with its CI rule. The session every
shell runs puts these and the reports together (:mod:`beatlog.suite_session`).

The names are imported on first use, so that a suite worker
(:mod:`beatlog.suite.worker`) starts with nothing but what replay needs.
"""

from typing import TYPE_CHECKING

from beatlog._lazy import lazy_names

if TYPE_CHECKING:
    from beatlog.suite.cluster import DaskExecutor
    from beatlog.suite.discovery import discover_specs, select_specs
    from beatlog.suite.fleet import fleet_specs
    from beatlog.suite.junit import write_junit
    from beatlog.suite.maintenance import Decision, approve, decide, update_baselines
    from beatlog.suite.options import SuiteOptions
    from beatlog.suite.parallel import run_suite
    from beatlog.suite.policy import UpdateMode
    from beatlog.suite.runner import SpecOutcome, Verdict, run_spec
    from beatlog.suite.sharding import Shard, shard
    from beatlog.suite.spec import SPEC_SUFFIX, DtcSpec, load_spec

__all__ = [
    "SPEC_SUFFIX",
    "DaskExecutor",
    "Decision",
    "DtcSpec",
    "Shard",
    "SpecOutcome",
    "SuiteOptions",
    "UpdateMode",
    "Verdict",
    "approve",
    "decide",
    "discover_specs",
    "fleet_specs",
    "load_spec",
    "run_spec",
    "run_suite",
    "select_specs",
    "shard",
    "update_baselines",
    "write_junit",
]

__getattr__ = lazy_names(
    __name__,
    {
        "SPEC_SUFFIX": "beatlog.suite.spec",
        "DaskExecutor": "beatlog.suite.cluster",
        "Decision": "beatlog.suite.maintenance",
        "DtcSpec": "beatlog.suite.spec",
        "UpdateMode": "beatlog.suite.policy",
        "approve": "beatlog.suite.maintenance",
        "decide": "beatlog.suite.maintenance",
        "update_baselines": "beatlog.suite.maintenance",
        "SpecOutcome": "beatlog.suite.runner",
        "SuiteOptions": "beatlog.suite.options",
        "Verdict": "beatlog.suite.runner",
        "discover_specs": "beatlog.suite.discovery",
        "fleet_specs": "beatlog.suite.fleet",
        "load_spec": "beatlog.suite.spec",
        "run_spec": "beatlog.suite.runner",
        "run_suite": "beatlog.suite.parallel",
        "select_specs": "beatlog.suite.discovery",
        "Shard": "beatlog.suite.sharding",
        "shard": "beatlog.suite.sharding",
        "write_junit": "beatlog.suite.junit",
    },
)
