"""DTC specs and suites: ``*.dtc.toml`` files, fleet runs of logs without specs, the
parallel runner and its Dask executor, shards for a CI matrix, JUnit output and the
re-baselining workflow (update, review, approve) with its CI rule. The session every
shell runs puts these and the reports together (:mod:`beatlog.report.session`).

The names are imported on first use, so that a suite worker
(:mod:`beatlog.suite.worker`) starts with nothing but what replay needs.
"""

from typing import TYPE_CHECKING

from beatlog.log._lazy import lazy_names

if TYPE_CHECKING:
    from beatlog.baseline.policy import UpdateMode as UpdateMode
    from beatlog.suite.cluster import DaskExecutor as DaskExecutor
    from beatlog.suite.discovery import discover_specs as discover_specs
    from beatlog.suite.discovery import select_specs as select_specs
    from beatlog.suite.junit import write_junit as write_junit
    from beatlog.suite.maintenance import Decision as Decision
    from beatlog.suite.maintenance import approve as approve
    from beatlog.suite.maintenance import decide as decide
    from beatlog.suite.maintenance import update_baselines as update_baselines
    from beatlog.suite.parallel import Shard as Shard
    from beatlog.suite.parallel import run_suite as run_suite
    from beatlog.suite.parallel import shard as shard
    from beatlog.suite.runner import SpecOutcome as SpecOutcome
    from beatlog.suite.runner import Verdict as Verdict
    from beatlog.suite.runner import run_spec as run_spec
    from beatlog.suite.selection import SuiteOptions as SuiteOptions
    from beatlog.suite.selection import fleet_specs as fleet_specs
    from beatlog.suite.spec import SPEC_SUFFIX as SPEC_SUFFIX
    from beatlog.suite.spec import DtcSpec as DtcSpec
    from beatlog.suite.spec import load_spec as load_spec

__getattr__ = lazy_names(__name__)
