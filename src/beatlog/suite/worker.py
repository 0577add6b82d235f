"""Suite workers: processes that replay the specs a suite runner hands them, one at a time.

``python -m beatlog.suite.worker`` is a worker's side; :class:`Worker` is the runner's
handle on one. A worker imports only what replay needs (not the CLI, not rich, the
audit only when auditing) and lives as long as its suite, so its start-up is paid once.
Specs and outcomes travel pickled over two pipes of their own (an outcome holds the
outputs behaviors gave, any Python object, which no schema encoding carries); the
worker's stdout and stderr stay the runner's, for what behaviors print.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import subprocess
import sys
import traceback
from types import FrameType
from typing import IO, TYPE_CHECKING, Any, cast

from beatlog.errors import BeatlogError
from beatlog.log.files import Closing
from beatlog.project.interpreters import quiet_abandoned_reads, start_interpreter, take_ctrl_c

if TYPE_CHECKING:
    from beatlog.audit.replays import Auditors
    from beatlog.baseline.policy import SpecOptions
    from beatlog.suite.runner import SpecOutcome
    from beatlog.suite.spec import DtcSpec

__all__ = ["Worker", "WorkerLostError", "serve"]

_READY = b"ready"
"""A worker's first message: it has imported what replay needs and waits for specs."""
STOP_S = 5.0
"""How long a worker asked to stop may take to unwind its work (remove a download's copy,
close a log) before it is killed; a busy machine needs more than a second or two."""
INTERRUPTED = 128 + signal.SIGINT
"""A worker's exit code when its work was interrupted: stopped by its runner, or Ctrl-C
reached a process it started (an audit interpreter) before it reached the runner."""


class WorkerLostError(BeatlogError):
    """A worker process ended without answering: it crashed or was killed."""


class Worker(Closing):
    """A worker process with the same ``sys.path`` as this one; a context manager that
    stops the worker on leaving (the audit interpreters it started follow it)."""

    def __init__(self) -> None:
        task_read, task_write = os.pipe()
        answer_read, answer_write = os.pipe()
        try:
            self._process = start_interpreter(
                __name__,
                [str(task_read), str(answer_write), *sys.path],
                pass_fds=(task_read, answer_write),
            )
        except BaseException:
            os.close(task_write)
            os.close(answer_read)
            raise
        finally:
            os.close(task_read)
            os.close(answer_write)
        self._tasks: IO[bytes] = os.fdopen(task_write, "wb")
        self._answers: IO[bytes] = os.fdopen(answer_read, "rb")
        self._ready = False
        self._stopped = False

    def wait_ready(self) -> None:
        """Block until the worker waits for specs (:class:`WorkerLostError` if it ended)."""
        if not self._ready:
            self._receive()
            self._ready = True

    def run(self, spec: DtcSpec, options: SpecOptions) -> SpecOutcome:
        """Replay ``spec`` in the worker, with ``options`` for
        :func:`~beatlog.suite.runner.run_spec`.

        :raises WorkerLostError: the worker ended before it answered.
        :raises KeyboardInterrupt: Ctrl-C interrupted the worker's work.
        :raises RuntimeError: ``run_spec`` raised in the worker (a programming error).
        """
        self.wait_ready()
        try:
            pickle.dump((spec, options), self._tasks)
            self._tasks.flush()
        except BrokenPipeError:
            raise self._lost() from None
        answer = self._receive()
        if isinstance(answer, BaseException):
            raise answer
        return cast("SpecOutcome", answer)

    def _receive(self) -> Any:
        try:
            return pickle.load(self._answers)  # noqa: S301 - from the worker we started
        except EOFError:
            raise self._lost() from None

    def _lost(self) -> BaseException:
        code = self._process.wait()
        if code == INTERRUPTED and not self._stopped:  # Ctrl-C, on its way to the runner
            return KeyboardInterrupt()
        if code >= 0:
            return WorkerLostError(f"the worker process ended (exit {code})")
        name = next((known.name for known in signal.Signals if known == -code), f"signal {-code}")
        return WorkerLostError(f"the worker process ended (killed by {name})")

    @property
    def stopped(self) -> bool:
        """Whether the worker was asked to stop (:meth:`stop`): its end is then no crash."""
        return self._stopped

    def stop(self) -> None:
        """Ask the worker to stop, whatever it is doing: its work unwinds as at Ctrl-C
        (the copy of a log it downloaded is removed), and it ends. Asking again does
        nothing."""
        if not self._stopped:
            self._stopped = True
            self._process.terminate()

    def close(self) -> None:
        """Stop the worker, kill it if it has not ended within :data:`STOP_S`, and wait
        for it to end."""
        self.stop()
        try:
            self._process.wait(STOP_S)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        self._tasks.close()
        self._answers.close()


def serve(tasks: IO[bytes], answers: IO[bytes]) -> None:
    """The worker's side: say it is ready, then replay each spec read from ``tasks`` and
    write its outcome to ``answers``, until ``tasks`` ends. The audit interpreters of
    audited specs are kept from one spec to the next, and stopped at the end."""
    from beatlog.suite.runner import run_spec, suite_auditors  # noqa: PLC0415 - after the signal handler

    pickle.dump(_READY, answers)
    answers.flush()
    with contextlib.ExitStack() as kept:
        auditors: Auditors | None = None
        while True:
            try:
                spec, options = pickle.load(tasks)  # noqa: S301 - from the runner that started us
            except EOFError:  # the runner is done, or gone
                return
            if auditors is None:
                auditors = kept.enter_context(suite_auditors(options))
            answer: SpecOutcome | RuntimeError
            try:
                answer = run_spec(spec, options, auditors=auditors)
            except Exception:  # a programming error: loud in the runner, with its traceback
                failure = traceback.format_exc()
                answer = RuntimeError(f"{spec.path}: the suite worker failed:\n{failure}")
            pickle.dump(answer, answers)
            answers.flush()


def _do_nothing(signum: int, frame: FrameType | None) -> None:
    """A signal handler that lets the signal pass."""


def _interrupt(signum: int, frame: FrameType | None) -> None:
    """A signal handler that interrupts the worker as Ctrl-C interrupts a program, once:
    the signal again lets the worker unwind. A download it stops (fsspec's HTTP reads
    are coroutines) is dropped unawaited, which is what stopping means: not a warning."""
    signal.signal(signum, _do_nothing)
    quiet_abandoned_reads()
    raise KeyboardInterrupt


def main() -> None:
    """``python -m beatlog.suite.worker TASKS ANSWERS PATH...``: the pipes' descriptors and
    the runner's ``sys.path``. Workers leave Ctrl-C to the runner, which stops them with
    SIGTERM: that unwinds the worker's work as Ctrl-C would, without a traceback from
    each (a handler that does nothing, not ``SIG_IGN``, so that the processes a worker
    starts, audit replays, are not born deaf to Ctrl-C)."""
    signal.signal(signal.SIGINT, _do_nothing)
    signal.signal(signal.SIGTERM, _interrupt)
    take_ctrl_c()
    tasks, answers, *path = sys.argv[1:]
    sys.path[:] = path
    try:
        with os.fdopen(int(tasks), "rb") as inbox, os.fdopen(int(answers), "wb") as outbox:
            serve(inbox, outbox)
    except KeyboardInterrupt:
        # Stopped, or Ctrl-C reached an audit interpreter first; its work unwound. End at
        # once, since a download it stopped can leave a read scheduled on fsspec's
        # event-loop thread and never started, which the interpreter's usual ending would
        # report as a coroutine never awaited.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(INTERRUPTED)


if __name__ == "__main__":
    main()
