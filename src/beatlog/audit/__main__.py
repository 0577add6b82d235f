"""``python -m beatlog.audit REQUEST LIFELINE PATH...``: one audited replay, the fresh
interpreter's side of :func:`beatlog.audit.audit`.

It imports from the auditing process's ``sys.path`` (``PATH...``), replays the request
(:class:`~beatlog.audit.replays.Request` as JSON) with every update watched for leaks
and hashed, and answers JSON (:class:`~beatlog.audit.replays.Answer`) on stdout.
Ctrl-C ends it at once, and so does its lifeline closing: the auditing process gave up
or died.
"""

from __future__ import annotations

import hashlib
import os
import signal
import sys
import threading
from collections.abc import Mapping
from typing import Any

import msgspec

from beatlog.audit.leaks import LeakWatch
from beatlog.audit.replays import CYCLE_DIGEST_SIZE, Answer, Request
from beatlog.errors import BeatlogError
from beatlog.log.format import payload_encoder
from beatlog.model.behavior import Behavior, System
from beatlog.model.context import Context
from beatlog.replay.judge import replay
from beatlog.usercode import load_system

__all__ = ["main"]


class _AuditedSystem:
    """A system whose every update is watched for leaks and hashed into a trace."""

    def __init__(self, system: System, watch: LeakWatch) -> None:
        self._system = system
        self._watch = watch
        self._behaviors = list(system.behaviors.values())
        self._encode = payload_encoder().encode
        self.trace: list[bytes] = []

    @property
    def robot_state(self) -> type[msgspec.Struct]:
        return self._system.robot_state

    @property
    def behaviors(self) -> Mapping[str, Behavior]:
        return self._system.behaviors

    def update(self, state: Any, context: Context) -> None:
        try:
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
    watch = LeakWatch()
    system = _AuditedSystem(load_system(request.system), watch)
    result = replay(request.log, system, keep_going=True, allow_truncated=request.allow_truncated)
    divergence = result.divergence
    return Answer(
        ok=result.ok,
        cycles=result.cycles,
        divergence_cycle=divergence.cycle if divergence else None,
        divergence_kind=divergence.kind if divergence else None,
        trace=b"".join(system.trace),
        findings=watch.findings(),
    )


def main() -> None:
    """Replay the request in argv and answer as JSON on stdout."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    request_json, lifeline, *path = sys.argv[1:]
    sys.path[:] = path
    request = msgspec.json.decode(request_json, type=Request)
    threading.Thread(target=_exit_when_orphaned, args=(int(lifeline),), daemon=True).start()
    answer_fd = os.dup(1)
    os.dup2(2, 1)  # what behaviors print must not corrupt the answer
    try:
        answer = _replay_watched(request)
    except BeatlogError as exc:
        answer = Answer(error=str(exc))
    with os.fdopen(answer_fd, "wb") as out:
        out.write(msgspec.json.encode(answer))


def _exit_when_orphaned(lifeline: int) -> None:
    """Read the lifeline until it closes: the auditing process gave up or died."""
    os.read(lifeline, 1)
    os._exit(1)


if __name__ == "__main__":
    main()
