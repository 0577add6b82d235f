"""Expected state changes approved after an intended behavior change, and pending ones.

Recordings are immutable: when behaviors change on purpose, the new state changes go
to a *pending* file beside the spec (``NAME.dtc.pending``), are reviewed, and once
approved become the *expected* file (``NAME.dtc.expected``) that replay judges against
instead of the recorded state changes. Both are plain text, one state change a line,
so a re-baseline reads as a diff in code review::

    # beatlog expected state changes, format 1
    # spec avoid-pole
    # log avoid-pole.beatlog sha256 5f0c...
    #  cycle      time  behavior: before -> after
         12     0.360  "avoid": "idle" -> "turning"

Behavior names and states are JSON, so loading a baseline never evaluates anything.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import tempfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from beatlog.engine.trace import TracedChange
from beatlog.engine.verdict import StateChange
from beatlog.errors import BaselineError
from beatlog.suite.spec import SPEC_SUFFIX

__all__ = [
    "EXPECTED_SUFFIX",
    "PENDING_SUFFIX",
    "Baseline",
    "expected_path",
    "find_orphans",
    "format_changes",
    "in_ci",
    "log_digest",
    "pending_path",
    "read_baseline",
    "write_baseline",
]

EXPECTED_SUFFIX = ".dtc.expected"
PENDING_SUFFIX = ".dtc.pending"
_MAGIC = "# beatlog expected state changes, format 1"
_LOG_LINE = re.compile(r"# log (?P<name>.+) sha256 (?P<digest>[0-9a-f]{64})")
_CHANGE_LINE = re.compile(r"\s*(?P<cycle>\d+)\s+(?P<time>\d+\.\d{3})\s+(?P<change>.*)")
_JSON = json.JSONDecoder()


@dataclass(frozen=True)
class Baseline:
    """A baseline file: the log it was made from and its state changes by cycle."""

    path: Path
    log_digest: str
    changes: tuple[TracedChange, ...]

    def by_cycle(self) -> dict[int, list[StateChange]]:
        """The state changes grouped by cycle, as replay expects them."""
        grouped: dict[int, list[StateChange]] = {}
        for traced in self.changes:
            grouped.setdefault(traced.cycle, []).append(traced.change)
        return grouped


def _base(spec: Path) -> str:
    name = spec.name
    return name[: -len(SPEC_SUFFIX)] if name.endswith(SPEC_SUFFIX) else spec.stem


def expected_path(spec: Path) -> Path:
    """Where the approved baseline of the spec at ``spec`` lives."""
    return spec.with_name(_base(spec) + EXPECTED_SUFFIX)


def pending_path(spec: Path) -> Path:
    """Where the pending (not yet approved) baseline of the spec at ``spec`` lives."""
    return spec.with_name(_base(spec) + PENDING_SUFFIX)


def in_ci() -> bool:
    """Whether the ``CI`` environment variable says this is a CI run (baselines stay put)."""
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def log_digest(log: Path) -> str:
    """The SHA-256 of a session log, binding a baseline to the recording it was made from."""
    digest = hashlib.sha256()
    try:
        with log.open("rb") as file:
            for block in iter(lambda: file.read(1 << 20), b""):
                digest.update(block)
    except OSError as exc:
        raise BaselineError(log, f"cannot read: {exc.strerror or exc}") from None
    return digest.hexdigest()


def format_changes(changes: Iterable[TracedChange]) -> list[str]:
    """One text line per state change, as baseline files hold them."""
    return [
        f"{cycle:>8} {time_ns / 1e9:>9.3f}  {json.dumps(change.behavior)}: "
        f"{json.dumps(change.before)} -> {json.dumps(change.after)}"
        for cycle, time_ns, change in changes
    ]


def write_baseline(
    path: Path, *, spec_name: str, log: Path, changes: Sequence[TracedChange]
) -> None:
    """Write a baseline file atomically: readers see the old file or the new one."""
    lines = [
        _MAGIC,
        f"# spec {spec_name}",
        f"# log {log.name} sha256 {log_digest(log)}",
        "#  cycle      time  behavior: before -> after",
        *format_changes(changes),
    ]
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(handle, "w", encoding="utf-8", newline="\n") as file:
            file.write("\n".join(lines) + "\n")
        Path(temporary).replace(path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def read_baseline(path: Path) -> Baseline:
    """Read a baseline file; anything else raises :class:`BaselineError` naming the line."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise BaselineError(path, "no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise BaselineError(path, f"cannot read: {exc}") from None
    lines = text.splitlines()
    if not lines or lines[0] != _MAGIC:
        raise BaselineError(path, "not a beatlog baseline (its first line is not the header)")
    digest = ""
    changes: list[TracedChange] = []
    for number, line in enumerate(lines[1:], start=2):
        if line.startswith("#"):
            found = _LOG_LINE.fullmatch(line)
            digest = found["digest"] if found else digest
        elif line.strip():
            changes.append(_parse_change(path, number, line))
    if not digest:
        raise BaselineError(path, "no '# log NAME sha256 DIGEST' line")
    return Baseline(path, digest, tuple(changes))


def _parse_change(path: Path, number: int, line: str) -> TracedChange:
    found = _CHANGE_LINE.fullmatch(line)
    try:
        if found is None:
            raise ValueError("expected 'CYCLE TIME \"behavior\": BEFORE -> AFTER'")
        text = found["change"]
        behavior, end = _JSON.raw_decode(text)
        end = _expect(text, end, ": ")
        before, end = _JSON.raw_decode(text, end)
        end = _expect(text, end, " -> ")
        after, end = _JSON.raw_decode(text, end)
        if end != len(text.rstrip()):
            raise ValueError(f"unexpected {text[end:]!r} after the state")
        if not isinstance(behavior, str):
            raise ValueError("the behavior must be a JSON string")
        for state in (before, after):
            if not isinstance(state, str | int | bool | None):
                raise ValueError(f"a state must be a string, number, flag or null, not {state!r}")
    except ValueError as exc:
        raise BaselineError(path, f"line {number}: {exc}") from None
    time_ns = round(float(found["time"]) * 1e9)
    return TracedChange(int(found["cycle"]), time_ns, StateChange(behavior, before, after))


def _expect(text: str, position: int, separator: str) -> int:
    if not text.startswith(separator, position):
        raise ValueError(f"expected {separator.strip()!r} at column {position + 1}")
    return position + len(separator)


def find_orphans(folders: Iterable[Path]) -> list[Path]:
    """Expected and pending files under ``folders`` whose spec no longer exists."""
    orphans: set[Path] = set()
    for folder in folders:
        if not folder.is_dir():
            continue
        for suffix in (EXPECTED_SUFFIX, PENDING_SUFFIX):
            for path in folder.rglob(f"*{suffix}"):
                hidden = any(p.startswith(".") for p in path.relative_to(folder).parts[:-1])
                spec = path.with_name(path.name[: -len(suffix)] + SPEC_SUFFIX)
                if path.is_file() and not hidden and not spec.is_file():
                    orphans.add(path)
    return sorted(orphans)
