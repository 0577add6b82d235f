"""Algorithm 2, replay: step a system through a session log and judge it.

:func:`replay` gives the verdict (pass, or the first divergence); :mod:`.compare`
holds the allowances a spec may grant, :mod:`.fit` checks a log fits the system, and
:mod:`.verdict` the result types.
"""

from beatlog.replay.compare import Comparison
from beatlog.replay.judge import replay
from beatlog.replay.verdict import (
    Divergence,
    DivergenceKind,
    DrawReport,
    ReplayResult,
    StateChange,
)

__all__ = [
    "Comparison",
    "Divergence",
    "DivergenceKind",
    "DrawReport",
    "ReplayResult",
    "StateChange",
    "replay",
]
