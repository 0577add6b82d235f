"""Algorithm 2, replay: step a system through a session log and judge it.

:func:`replay` gives the verdict (pass, or the first divergence); :mod:`.compare`
holds the allowances a spec may grant, :mod:`.fit` checks a log fits the system,
:mod:`.migration` maps robot-state fields renamed or retyped since the recording, and
:mod:`.verdict` the result types. The names are imported on first use.
"""

from typing import TYPE_CHECKING

from beatlog._lazy import lazy_names

if TYPE_CHECKING:
    from beatlog.replay.compare import Comparison
    from beatlog.replay.expectation import Expectation
    from beatlog.replay.judge import replay
    from beatlog.replay.migration import StateMigration
    from beatlog.replay.verdict import (
        Checked,
        Divergence,
        DivergenceKind,
        DrawReport,
        ReplayResult,
        StateChange,
    )

__all__ = [
    "Checked",
    "Comparison",
    "Divergence",
    "DivergenceKind",
    "DrawReport",
    "Expectation",
    "ReplayResult",
    "StateChange",
    "StateMigration",
    "replay",
]

__getattr__ = lazy_names(
    __name__,
    {
        "Checked": "beatlog.replay.verdict",
        "Comparison": "beatlog.replay.compare",
        "Divergence": "beatlog.replay.verdict",
        "DivergenceKind": "beatlog.replay.verdict",
        "DrawReport": "beatlog.replay.verdict",
        "Expectation": "beatlog.replay.expectation",
        "ReplayResult": "beatlog.replay.verdict",
        "StateChange": "beatlog.replay.verdict",
        "StateMigration": "beatlog.replay.migration",
        "replay": "beatlog.replay.judge",
    },
)
