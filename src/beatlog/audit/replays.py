"""The determinism audit: does a DTC's replay depend on anything but its log and code?

:func:`audit` replays a log twice, each time in an interpreter of its own with its own
``PYTHONHASHSEED``; :class:`Auditors` owns the two interpreters, started at its first
audit and kept for the next ones until it closes, so a suite pays their start-up once.
During each replay a :class:`~beatlog.project.leaks.LeakWatch` turns the wall-clock
reads and global random calls the system makes while it updates into findings that
name the call site, and every cycle's behavior states and outputs are hashed. The two
replays must agree on the verdict and on every cycle; where they do not, set or dict
order of strings leaks into the behaviors' decisions.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import signal
import subprocess
import sys
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import IO

import msgspec

from beatlog.errors import BeatlogError
from beatlog.log.files import Closing
from beatlog.project.interpreters import start_interpreter
from beatlog.project.leaks import Finding
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.verdict import DivergenceKind

__all__ = ["AuditReport", "Auditors", "Finding", "SeedRun", "audit"]

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
        lines = [str(finding) for finding in self.findings]
        if self.hash_seed_dependence is not None:
            lines.append(self.hash_seed_dependence)
        return lines


def audit(
    log: str | Path,
    system: str,
    *,
    allow_truncated: bool = False,
    hash_seeds: tuple[int, int] = (1, 2),
    migration: StateMigration | None = None,
    auditors: Auditors | None = None,
) -> AuditReport:
    """Replay ``log`` against ``system`` (a ``module:factory`` reference) once per hash
    seed, at once, each in an audit interpreter of ``auditors`` (by default this audit's
    own) importing from this process's ``sys.path``, every cycle, diverging or not.

    The first replay is watched for leaks, the second only hashed: they run the same
    code unless the hash seed changes what it does, which the hashes show; then both are
    run again, watched, so that no leak on either path goes unseen.

    :raises beatlog.errors.BeatlogError: the log or the system is bad input.
    """
    migration = migration or StateMigration()
    request = Request(
        str(log),
        system,
        allow_truncated,
        list(sys.path),
        dict(os.environ),
        field_renames=dict(migration.renames),
        field_conversions=dict(migration.conversions),
    )
    with Auditors() if auditors is None else contextlib.nullcontext(auditors) as used:
        first, second = used.replays(
            hash_seeds, [request, msgspec.structs.replace(request, watch=False)]
        )
        runs = (_seed_run(hash_seeds[0], first), _seed_run(hash_seeds[1], second))
        if _compare(runs, first.trace, second.trace, "") is not None:  # they took other paths
            first, second = used.replays(hash_seeds, [request, request])
            runs = (_seed_run(hash_seeds[0], first), _seed_run(hash_seeds[1], second))
    findings = _merge(first.findings, second.findings)
    return AuditReport(
        findings=findings,
        runs=runs,
        hash_seed_dependence=_compare(runs, first.trace, second.trace, _cause(findings)),
    )


class Auditors(Closing):
    """The audit interpreters, one per hash seed, each started at the first audit that
    needs it and kept for the audits that follow; closing stops them. A suite run keeps
    one for its audits (see :func:`audit`)."""

    def __init__(self) -> None:
        self._auditors: dict[int, _Auditor] = {}
        self._lock = threading.Lock()

    def replays(
        self, hash_seeds: tuple[int, int], requests: list[Request]
    ) -> tuple[Answer, Answer]:
        """Each request replayed by the audit interpreter of its hash seed, at once.

        :raises beatlog.errors.BeatlogError: the log or the system is bad input.
        """
        with self._lock:
            try:
                auditors = [self._auditor(seed) for seed in hash_seeds]
                for auditor, request in zip(auditors, requests, strict=True):
                    auditor.send(request)
                first, second = (auditor.receive() for auditor in auditors)  # all, then judge
            except BaseException:  # Ctrl-C above all: no replay goes on without us
                for seed in hash_seeds:
                    self._stop(seed)
                raise
        for answer in (first, second):
            if answer.error is not None:
                raise BeatlogError(answer.error)
        return first, second

    def close(self) -> None:
        """Stop every audit interpreter."""
        for hash_seed in list(self._auditors):
            self._stop(hash_seed)

    def _auditor(self, hash_seed: int) -> _Auditor:
        """The audit interpreter for ``hash_seed``, started if there is none yet."""
        if hash_seed not in self._auditors:
            self._auditors[hash_seed] = _Auditor(hash_seed)
        return self._auditors[hash_seed]

    def _stop(self, hash_seed: int) -> None:
        auditor = self._auditors.pop(hash_seed, None)
        if auditor is not None:
            auditor.close()


class _Auditor:
    """An audit interpreter with one ``PYTHONHASHSEED``, replaying request after request,
    until its lifeline closes; its stderr is kept for the last request, to show if it
    crashes."""

    def __init__(self, hash_seed: int) -> None:
        self.hash_seed = hash_seed
        lifeline, self._held = os.pipe()
        self._errors: IO[bytes] = tempfile.TemporaryFile(mode="a+b")  # noqa: SIM115 - closed by close()
        try:
            self._process = start_interpreter(
                "beatlog.audit",
                [str(lifeline), *sys.path],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=self._errors,
                env={**os.environ, "PYTHONHASHSEED": str(hash_seed)},
                pass_fds=(lifeline,),
            )
        except BaseException:
            os.close(self._held)
            self._errors.close()
            raise
        finally:
            os.close(lifeline)

    def send(self, request: Request) -> None:
        self._errors.truncate(0)
        assert self._process.stdin is not None
        try:
            self._process.stdin.write(msgspec.json.encode(request) + b"\n")
            self._process.stdin.flush()
        except BrokenPipeError:
            raise self._crashed() from None

    def receive(self) -> Answer:
        assert self._process.stdout is not None
        line = self._process.stdout.readline()
        if not line:
            raise self._crashed()
        return msgspec.json.decode(line, type=Answer)

    def _crashed(self) -> BaseException:
        code = self._process.wait()
        if code == -signal.SIGINT:  # Ctrl-C reached the interpreter before this process
            return KeyboardInterrupt()
        self._errors.seek(0)
        return RuntimeError(
            f"the audit replay with PYTHONHASHSEED={self.hash_seed} crashed (exit {code}):\n"
            + self._errors.read().decode(errors="replace")
        )

    def close(self) -> None:
        self._process.kill()
        self._process.wait()
        for stream in (self._process.stdin, self._process.stdout, self._errors):
            if stream is not None:
                stream.close()
        os.close(self._held)


class Request(msgspec.Struct, array_like=True):
    """What to replay: a JSON line to ``python -m beatlog.audit``."""

    log: str
    system: str
    allow_truncated: bool
    path: list[str]
    """The auditing process's ``sys.path``, to import the system from."""
    environ: dict[str, str]
    """The auditing process's environment, for the system to see."""
    watch: bool = True
    """Whether to watch the updates for leaks (else only hash them)."""
    field_renames: dict[str, str] = {}
    """Robot-state fields renamed since the recording (:class:`StateMigration`)."""
    field_conversions: dict[str, str] = {}
    """Robot-state fields retyped since the recording, and their conversions."""


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
_UNSEEDED = "unseeded "
"""How a finding of a generator of the system's own made without a seed begins."""


def _cause(findings: tuple[Finding, ...]) -> str:
    """What makes two replays differ, from the findings: an unseeded random generator of
    the system's own or a global one when the behaviors draw from one, else the hash seed."""
    own = sorted({f.call.removeprefix(_UNSEEDED) for f in findings if f.call.startswith(_UNSEEDED)})
    if own:
        return f"the replay draws from an unseeded random generator ({', '.join(own)})"
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
    size, common = CYCLE_DIGEST_SIZE, min(len(first), len(second))
    offset = next(
        (at for at in range(0, common, size) if first[at : at + size] != second[at : at + size]),
        common,
    )
    cycle = offset // size
    return (
        f"{cause}: with PYTHONHASHSEED={a.hash_seed} and "
        f"{b.hash_seed} the behavior states and outputs differ from cycle {cycle}"
    )
