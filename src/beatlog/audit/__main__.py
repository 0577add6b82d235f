"""``python -m beatlog.audit LIFELINE PATH...``: an audit interpreter, the other side of
:func:`beatlog.audit.audit`, started once with its ``PYTHONHASHSEED`` and kept for every
DTC its auditing process audits.

It reads requests (:class:`~beatlog.audit.replays.Request`, a JSON line each) on stdin,
replays each with every update hashed (and, when the request asks, watched for leaks),
importing from the request's ``sys.path``, and answers a JSON line
(:class:`~beatlog.audit.replays.Answer`) on stdout. A watched request is first replayed
under a cheap screen; only a replay the screen finds suspicious is run again under the
watch, which follows the lines of user code only when numpy's global generator moved.
Ctrl-C ends it at once, and so does its lifeline closing: the auditing process gave up
or died.
"""

from __future__ import annotations

import hashlib
import os
import signal
import sys
import threading
from typing import Any

import msgspec

from beatlog.audit.replays import CYCLE_DIGEST_SIZE, Answer, Request
from beatlog.errors import BeatlogError
from beatlog.log.format import payload_encoder
from beatlog.model.behavior import System
from beatlog.model.context import Context
from beatlog.model.source import RandomSource
from beatlog.project.interpreters import take_ctrl_c
from beatlog.project.leaks import LeakScreen, LeakWatch, built_watched
from beatlog.project.usercode import load_system
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.judge import replay

__all__ = ["main"]


class _AuditedSystem:
    """A system whose every update is hashed into a trace and, given a watch, watched
    for leaks."""

    def __init__(self, system: System, watch: LeakWatch | LeakScreen | None) -> None:
        self._system = system
        self._watch = watch
        self.robot_state = system.robot_state
        self.behaviors = system.behaviors
        self._behaviors = list(system.behaviors.values())
        self._encode = payload_encoder().encode
        self.trace: list[bytes] = []

    def update(self, state: Any, context: Context) -> None:
        try:
            if self._watch is None:
                self._system.update(state, context)
            else:
                with self._watch:
                    self._system.update(state, context)
        finally:  # a cycle that raised is part of the trace too
            self.trace.append(self._digest(context))

    def _digest(self, context: Context) -> bytes:
        try:
            data = self._encode(([b.state for b in self._behaviors], context.outputs))
        except (TypeError, msgspec.EncodeError):  # unloggable outputs: replay reports them
            data = b""
        return hashlib.blake2b(data, digest_size=CYCLE_DIGEST_SIZE).digest()


def _replay_watched(request: Request) -> Answer:
    """The answer of a replay, watched for leaks when the request asks: screened first
    (cheap), and only where the screen saw a watched call run again under a watch, which
    follows the lines of user code where numpy's global generator moved."""
    if not request.watch:
        return _replay(request, None)
    screen = LeakScreen()
    answer = _replay(request, screen)
    if not screen.suspicious:
        return answer
    return _replay(request, LeakWatch(lines=screen.numpy_moved))


def _replay(request: Request, watch: LeakWatch | LeakScreen | None) -> Answer:
    audited: list[_AuditedSystem] = []

    def build(random: RandomSource) -> _AuditedSystem:
        """The audited system, built once the header is read: its factory draws the
        recorded set-up draws, which are no leak."""
        if watch is None:
            built = load_system(request.system, random=random)
        else:  # the numpy generators the set-up seeded from the OS are watched too
            built, watch.generators = built_watched(
                lambda: load_system(request.system, random=random)
            )
        audited.append(_AuditedSystem(built, watch))
        return audited[-1]

    result = replay(
        request.log,
        build,
        keep_going=True,
        allow_truncated=request.allow_truncated,
        allow_empty=True,  # the audit compares replays; the verdict judges what they checked
        migration=StateMigration(request.field_renames, request.field_conversions),
    )
    divergence = result.divergence
    return Answer(
        ok=result.ok,
        cycles=result.cycles,
        divergence_cycle=divergence.cycle if divergence else None,
        divergence_kind=divergence.kind if divergence else None,
        trace=b"".join(audited[0].trace) if audited else b"",
        findings=[] if watch is None else watch.findings(),
    )


def main() -> None:
    """Replay each request read from stdin and answer each as a JSON line on stdout."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    take_ctrl_c()
    lifeline, *path = sys.argv[1:]
    sys.path[:] = path
    threading.Thread(target=_exit_when_orphaned, args=(int(lifeline),), daemon=True).start()
    requests = os.fdopen(os.dup(0), "rb")
    answers = os.fdopen(os.dup(1), "wb")
    os.dup2(os.open(os.devnull, os.O_RDONLY), 0)  # behaviors read nothing of the requests
    os.dup2(2, 1)  # what behaviors print must not corrupt the answers
    for line in requests:
        request = msgspec.json.decode(line, type=Request)
        sys.path[:] = request.path
        seed = os.environ["PYTHONHASHSEED"]  # the request's environment, but our hash seed
        os.environ.clear()
        os.environ.update(request.environ, PYTHONHASHSEED=seed)
        try:
            answer = _replay_watched(request)
        except BeatlogError as exc:
            answer = Answer(error=str(exc))
        answers.write(msgspec.json.encode(answer) + b"\n")
        answers.flush()


def _exit_when_orphaned(lifeline: int) -> None:
    """Read the lifeline until it closes: the auditing process gave up or died."""
    os.read(lifeline, 1)
    os._exit(1)


if __name__ == "__main__":
    main()
