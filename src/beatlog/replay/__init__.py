"""Algorithm 2, the replay engine: step a system through a session log and judge it.

Called, ``beatlog.replay(log, system)`` is its public face (it also judges against a
spec's approved baseline); :func:`.judge.replay` gives the verdict (pass, or the first
divergence), :mod:`.compare` holds the allowances a spec may grant, :mod:`.fit` checks a
log fits the system and maps robot-state fields renamed or retyped since the recording,
and :mod:`.verdict` the result types. The names are imported on first use.
"""

from typing import TYPE_CHECKING

from beatlog.log._lazy import lazy_names

if TYPE_CHECKING:
    from beatlog.replay.baseline import Baseline as Baseline
    from beatlog.replay.compare import Comparison as Comparison
    from beatlog.replay.fit.migration import StateMigration as StateMigration
    from beatlog.replay.verdict import Checked as Checked
    from beatlog.replay.verdict import Divergence as Divergence
    from beatlog.replay.verdict import DivergenceKind as DivergenceKind
    from beatlog.replay.verdict import RandomDraw as RandomDraw
    from beatlog.replay.verdict import ReplayResult as ReplayResult
    from beatlog.replay.verdict import StateChange as StateChange

__getattr__ = lazy_names(__name__)
