"""Everything a baseline is: the approved departures from a recording that replay judges
against after an intended change, in one current file format (:mod:`.file`, read by
:mod:`.read`, its digests checked by :mod:`.digests`, written by :mod:`.write`), the
command that rewrites older files in it (:mod:`.upgrade`), and when baselines may be
written and go stale (:mod:`.policy`).

The per-cycle parts replay itself checks (the approved robot states, draws and outputs,
and departures) live with the replay core, in :mod:`beatlog.replay`, a layer
below; the re-baselining workflow over a suite's specs (update, review, approve) lives
in :mod:`beatlog.suite.maintenance`. The names are imported on first use.
"""

from typing import TYPE_CHECKING

from beatlog.log._lazy import lazy_names

if TYPE_CHECKING:
    from beatlog.baseline.file import BaselineFile as BaselineFile
    from beatlog.baseline.file import expected_path as expected_path
    from beatlog.baseline.file import pending_path as pending_path
    from beatlog.baseline.file import read_baseline as read_baseline
    from beatlog.baseline.policy import UpdateMode as UpdateMode
    from beatlog.baseline.upgrade import upgrade_baselines as upgrade_baselines
    from beatlog.baseline.write import write_baseline as write_baseline

__getattr__ = lazy_names(__name__)
