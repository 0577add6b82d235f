"""The record and replay engines, the verdict a replay gives and the determinism audit."""

from beatlog.engine.audit import AuditReport, Finding, SeedRun, audit
from beatlog.engine.cycle import CycleExecutor
from beatlog.engine.loading import load_factory, load_system
from beatlog.engine.record import Recorder, RecordSummary
from beatlog.engine.replay import replay
from beatlog.engine.trace import Expectation
from beatlog.engine.verdict import (
    Divergence,
    DivergenceKind,
    DrawReport,
    ReplayResult,
    StateChange,
)

__all__ = [
    "AuditReport",
    "CycleExecutor",
    "Divergence",
    "DivergenceKind",
    "DrawReport",
    "Expectation",
    "Finding",
    "RecordSummary",
    "Recorder",
    "ReplayResult",
    "SeedRun",
    "StateChange",
    "audit",
    "load_factory",
    "load_system",
    "replay",
]
