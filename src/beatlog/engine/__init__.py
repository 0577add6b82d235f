"""The record and replay engines and the verdict a replay gives."""

from beatlog.engine.cycle import CycleExecutor
from beatlog.engine.loading import load_factory, load_system
from beatlog.engine.record import Recorder, RecordSummary
from beatlog.engine.replay import replay
from beatlog.engine.verdict import (
    Divergence,
    DivergenceKind,
    DrawReport,
    ReplayResult,
    StateChange,
)

__all__ = [
    "CycleExecutor",
    "Divergence",
    "DivergenceKind",
    "DrawReport",
    "RecordSummary",
    "Recorder",
    "ReplayResult",
    "StateChange",
    "load_factory",
    "load_system",
    "replay",
]
