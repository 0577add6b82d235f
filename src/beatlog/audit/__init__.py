"""The determinism audit: replays in fresh interpreters under two hash seeds, with a
leak watch naming wall-clock reads and global random calls in user code.

``python -m beatlog.audit`` is the fresh interpreter's side (:mod:`.__main__`); the
names here are imported on first use, so that it starts light.
"""

from typing import TYPE_CHECKING

from beatlog.log._lazy import lazy_names

if TYPE_CHECKING:
    from beatlog.audit.replays import Auditors as Auditors
    from beatlog.audit.replays import AuditReport as AuditReport
    from beatlog.audit.replays import Finding as Finding
    from beatlog.audit.replays import SeedRun as SeedRun
    from beatlog.audit.replays import audit as audit

__getattr__ = lazy_names(__name__)
