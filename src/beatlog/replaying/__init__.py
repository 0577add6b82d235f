"""Algorithm 2, the replay engine: step a system through a session log and judge it.

:func:`beatlog.replay` is its public face (it also judges against a spec's approved
baseline). Here :func:`replay` gives the verdict (pass, or the first divergence);
:mod:`.compare` holds the allowances a spec may grant, :mod:`.fit` checks a log fits the
system and maps robot-state fields renamed or retyped since the recording, and
:mod:`.verdict` the result types. The names are imported on first use.
"""

from typing import TYPE_CHECKING

from beatlog.log._lazy import lazy_names

if TYPE_CHECKING:
    from beatlog.replaying.compare import Comparison as Comparison
    from beatlog.replaying.expectation import Expectation as Expectation
    from beatlog.replaying.fit.migration import StateMigration as StateMigration
    from beatlog.replaying.judge import replay as replay
    from beatlog.replaying.verdict import Checked as Checked
    from beatlog.replaying.verdict import Divergence as Divergence
    from beatlog.replaying.verdict import DivergenceKind as DivergenceKind
    from beatlog.replaying.verdict import DrawReport as DrawReport
    from beatlog.replaying.verdict import ReplayResult as ReplayResult
    from beatlog.replaying.verdict import StateChange as StateChange

__getattr__ = lazy_names(__name__)
