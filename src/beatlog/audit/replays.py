"""The determinism audit: does a DTC's replay depend on anything but its log and code?

:func:`audit` replays a log twice, each time in a fresh interpreter with its own
``PYTHONHASHSEED``. During each replay a :class:`~beatlog.audit.leaks.LeakWatch`
turns the wall-clock reads and global random calls the system makes while it updates
into findings that name the call site, and every cycle's behavior states and outputs
are hashed. The two replays must agree on the verdict and on every cycle; where they
do not, set or dict order of strings leaks into the behaviors' decisions.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import msgspec

from beatlog.audit.leaks import Finding
from beatlog.errors import BeatlogError
from beatlog.replay.verdict import DivergenceKind

__all__ = ["AuditReport", "Finding", "SeedRun", "audit"]

CYCLE_DIGEST_SIZE = 8
"""Bytes of blake2b per replayed cycle in an answer's trace."""


@dataclass(frozen=True)
class SeedRun:
    """One audited replay, in a fresh interpreter with ``PYTHONHASHSEED`` set."""

    hash_seed: int
    ok: bool
    cycles: int
    divergence_cycle: int | None
    divergence_kind: DivergenceKind | None
    digest: str
    """blake2b of every replayed cycle's behavior states and outputs."""

    def describe(self) -> str:
        """``passed`` or where it diverged."""
        if self.ok:
            return "passed"
        kind = self.divergence_kind.value if self.divergence_kind else "?"
        return f"diverged at cycle {self.divergence_cycle} ({kind})"


@dataclass(frozen=True)
class AuditReport:
    """What the audit of one log found; it is clean when there is nothing to report."""

    findings: tuple[Finding, ...]
    """Wall-clock reads and global random calls, by call and site (the larger count of the runs)."""
    runs: tuple[SeedRun, SeedRun]
    hash_seed_dependence: str | None
    """How the two runs differed, or None when they agree in every cycle."""

    @property
    def problems(self) -> int:
        """Findings plus one if the replay depends on the hash seed."""
        return len(self.findings) + (self.hash_seed_dependence is not None)

    @property
    def ok(self) -> bool:
        """Whether the audit found nothing."""
        return self.problems == 0

    def summary(self) -> str:
        """``no findings``, ``1 finding`` or ``N findings``."""
        return f"{self.problems or 'no'} finding{'' if self.problems == 1 else 's'}"

    def lines(self) -> list[str]:
        """Every problem in one line each, for reports."""
        lines = [
            f"{finding.call} at {finding.site} ({_times(finding.count)})"
            + ("" if finding.via is None else f", from {finding.via}")
            for finding in self.findings
        ]
        if self.hash_seed_dependence is not None:
            lines.append(self.hash_seed_dependence)
        return lines


def _times(count: int) -> str:
    return "once" if count == 1 else f"{count:,} times"


def audit(
    log: str | Path,
    system: str,
    *,
    allow_truncated: bool = False,
    hash_seeds: tuple[int, int] = (1, 2),
) -> AuditReport:
    """Replay ``log`` against ``system`` (a ``module:factory`` reference) once per hash seed.

    Both replays run at once, each in a fresh interpreter (``python -m beatlog.audit``,
    see :mod:`beatlog.audit.__main__`) that imports from this one's ``sys.path``; each
    replays every cycle, diverging or not, so the runs compare in full.

    :raises beatlog.errors.BeatlogError: the log or the system is bad input.
    """
    request = msgspec.json.encode(Request(str(log), system, allow_truncated)).decode()
    lifeline, held = os.pipe()  # the children exit when ``held`` closes, even if we are killed
    children: list[subprocess.Popen[bytes]] = []
    with contextlib.ExitStack() as stack:
        stack.callback(os.close, held)
        try:
            for seed in hash_seeds:
                child = subprocess.Popen(
                    [sys.executable, "-m", "beatlog.audit", request, str(lifeline), *sys.path],
                    stdout=subprocess.PIPE,
                    stderr=subprocess.PIPE,
                    env={**os.environ, "PYTHONHASHSEED": str(seed)},
                    pass_fds=(lifeline,),
                )
                children.append(stack.enter_context(child))
            outputs = [child.communicate() for child in children]  # all, before judging any
        except BaseException:  # Ctrl-C above all: no replay goes on without us
            for child in children:
                child.kill()
            raise
        finally:
            os.close(lifeline)
    first, second = (
        _answer(seed, child.returncode, *output)
        for seed, child, output in zip(hash_seeds, children, outputs, strict=True)
    )
    runs = (_seed_run(hash_seeds[0], first), _seed_run(hash_seeds[1], second))
    return AuditReport(
        findings=_merge(first.findings, second.findings),
        runs=runs,
        hash_seed_dependence=_compare(
            runs, first.trace, second.trace, _cause(_merge(first.findings, second.findings))
        ),
    )


class Request(msgspec.Struct, array_like=True):
    """What to replay, as the first argument of ``python -m beatlog.audit``."""

    log: str
    system: str
    allow_truncated: bool


class Answer(msgspec.Struct, kw_only=True):
    """What a child replay tells its parent, as JSON on its own stdout."""

    ok: bool = False
    cycles: int = 0
    divergence_cycle: int | None = None
    divergence_kind: DivergenceKind | None = None
    trace: bytes = b""
    """Every cycle's digest, one after the other."""
    findings: list[Finding] = msgspec.field(default_factory=list)
    error: str | None = None
    """Bad input (log or system) that stopped the replay."""


def _answer(seed: int, returncode: int, out: bytes, err: bytes) -> Answer:
    if returncode != 0:
        raise RuntimeError(
            f"the audit replay with PYTHONHASHSEED={seed} crashed (exit {returncode}):\n"
            + err.decode(errors="replace")
        )
    answer = msgspec.json.decode(out, type=Answer)
    if answer.error is not None:
        raise BeatlogError(answer.error)
    return answer


def _seed_run(seed: int, answer: Answer) -> SeedRun:
    return SeedRun(
        hash_seed=seed,
        ok=answer.ok,
        cycles=answer.cycles,
        divergence_cycle=answer.divergence_cycle,
        divergence_kind=answer.divergence_kind,
        digest=hashlib.blake2b(answer.trace, digest_size=16).hexdigest(),
    )


def _merge(*runs: list[Finding]) -> tuple[Finding, ...]:
    counts: dict[tuple[str, str, str | None], int] = {}
    for findings in runs:
        for finding in findings:
            key = (finding.call, finding.site, finding.via)
            counts[key] = max(counts.get(key, 0), finding.count)
    return tuple(Finding(call, site, count, via) for (call, site, via), count in counts.items())


_GLOBAL_RANDOM = ("random.", "numpy.random", "os.urandom", "uuid.")


def _cause(findings: tuple[Finding, ...]) -> str:
    """What makes two replays differ, from the findings: an unseeded global random
    generator when the behaviors draw from one, else the hash seed."""
    draws = sorted({f.call for f in findings if f.call.startswith(_GLOBAL_RANDOM)})
    if draws:
        return f"the replay draws from an unseeded global random generator ({', '.join(draws)})"
    return "the replay depends on the hash seed"


def _compare(runs: tuple[SeedRun, SeedRun], first: bytes, second: bytes, cause: str) -> str | None:
    a, b = runs
    verdicts = (a.ok, a.divergence_cycle, a.divergence_kind)
    if verdicts != (b.ok, b.divergence_cycle, b.divergence_kind):
        return (
            f"{cause}: PYTHONHASHSEED={a.hash_seed} "
            f"{a.describe()}, PYTHONHASHSEED={b.hash_seed} {b.describe()}"
        )
    if first == second:
        return None
    cycle = next(
        (
            offset // CYCLE_DIGEST_SIZE
            for offset in range(0, min(len(first), len(second)), CYCLE_DIGEST_SIZE)
            if first[offset : offset + CYCLE_DIGEST_SIZE]
            != second[offset : offset + CYCLE_DIGEST_SIZE]
        ),
        min(len(first), len(second)) // CYCLE_DIGEST_SIZE,
    )
    return (
        f"{cause}: with PYTHONHASHSEED={a.hash_seed} and "
        f"{b.hash_seed} the behavior states and outputs differ from cycle {cycle}"
    )
