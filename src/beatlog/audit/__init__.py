"""The determinism audit: replays in fresh interpreters under two hash seeds, with a
leak watch naming wall-clock reads and global random calls in user code."""

from beatlog.audit.replays import AuditReport, Finding, SeedRun, audit

__all__ = ["AuditReport", "Finding", "SeedRun", "audit"]
