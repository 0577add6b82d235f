"""The record engine (the paper's Algorithm 1), for a robot's own main loop or as a ready loop.

:meth:`Recorder.step` runs exactly one cycle, for robots that own their loop;
:meth:`Recorder.run` is the loop itself: wait for the heartbeat, fold the sensor
samples into the robot state, step, act. Like py_trees' ``tick`` and ``tick_tock``.
"""

from __future__ import annotations

import logging
import platform
import subprocess
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import TracebackType
from typing import IO, TYPE_CHECKING, Any, NamedTuple

import msgspec

from beatlog._version import __version__
from beatlog.errors import NumpyMissingError, SchemaMismatchError
from beatlog.log.columns import COLUMNS_FROM
from beatlog.log.format import FORMAT_VERSION, SessionEnd, SessionHeader, payload_encoder
from beatlog.log.writer import SessionLogWriter
from beatlog.model.behavior import System
from beatlog.model.clock import DEFAULT_PERIOD_NS, LiveHeartbeat
from beatlog.model.context import Outputs
from beatlog.model.cycle import CycleExecutor
from beatlog.model.inbox import Sample
from beatlog.model.random import RecordingRandom
from beatlog.model.robot import Robot
from beatlog.model.setup import SystemFactory
from beatlog.model.state import state_fields, state_schema, state_type_name

if TYPE_CHECKING:
    from beatlog.model.invariant import Invariant
    from beatlog.record.certify import Certificate
    from beatlog.replay.invariants import InvariantChecker, Violation

__all__ = ["MAX_VIOLATIONS", "RecordSummary", "Recorder", "software_version"]

_log = logging.getLogger(__name__)


MAX_VIOLATIONS = 1000
"""The most invariant violations a recorder keeps: a robot may run for hours."""


class RecordSummary(NamedTuple):
    """What a recording run produced."""

    cycles: int
    robot_time_ns: int
    overruns: int
    error: str | None
    """Why the log stopped being written (e.g. disk full); the robot kept running."""


def software_version(directory: Path | None = None) -> str:
    """``git describe`` of the working tree, or ``"unknown"`` outside a git checkout."""
    try:
        described = subprocess.run(
            ["git", "describe", "--always", "--dirty", "--tags"],  # noqa: S607
            cwd=directory,
            capture_output=True,
            text=True,
            timeout=5,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return described.stdout.strip() or "unknown"


class Recorder:
    """Records a system's session into a ``.beatlog`` file; a context manager.

    :param path: the ``.beatlog`` to write, or an open binary file to write it to (left
        open when the recorder closes).
    :param overwrite: replace a log already at ``path``; without it an existing log is
        never touched and :class:`~beatlog.errors.LogExistsError` names it.
    :param robot_id: the robot's name, kept in the header (``beatlog show`` prints it).
    :param system_ref: the ``module:factory`` that built the system, kept in the header
        for reports' replay commands (and replays without a system, where the project
        lists it under ``[tool.beatlog] systems``).
    :param period_ns: the heartbeat period the robot aims for, in ns.
    :param seed: seed of the random source; a fresh one from the OS when None.
    :param random: the random source the system's factory drew its set-up from
        (:mod:`beatlog.model.setup`): those draws are kept in the header, and it goes on
        as the session's source; not with ``seed`` (give the seed to the source).
    :param flush_interval_s: robot time between flushes to disk; a recorder killed
        loses at most this much.
    :param fsync: also ``fsync`` at every flush.
    :param log_samples: also log the raw sensor samples folded into each robot state.
    :param software: the robot software's version, kept in the header (by default
        ``git describe`` of the working directory, or ``unknown``).
    :param start_time_ns: the wall-clock start of the recording (Unix ns; by default
        now); never used by replay.
    :param clock: the monotonic clock, in ns, that :meth:`beat` measures the heartbeat
        intervals with; a simulated robot passes its simulator's.
    :param by_field: store the robot states by field (format 3's columns: a replay
        decodes only the fields its behaviors read), or in the cycle records; by default
        by field from :data:`~beatlog.log.columns.COLUMNS_FROM` fields.
    :param certify: a factory of the recorded system: when the session ends without an
        exception, the log (at a ``path``) is replayed against a fresh system from it, and
        :attr:`certificate` says whether it replays (:mod:`beatlog.record.certify`).
    :param invariants: invariants to check in each cycle as it is recorded
        (:mod:`beatlog.model.invariant`): a violation never stops the robot; it is kept
        in :attr:`violations`, each invariant's first logged as a warning.
    """

    def __init__(
        self,
        path: str | Path | IO[bytes],
        system: System,
        *,
        overwrite: bool = False,
        robot_id: str = "robot",
        system_ref: str = "",
        period_ns: int = DEFAULT_PERIOD_NS,
        seed: int | None = None,
        flush_interval_s: float = 1.0,
        fsync: bool = False,
        log_samples: bool = False,
        software: str | None = None,
        start_time_ns: int | None = None,
        clock: Callable[[], int] = time.monotonic_ns,
        by_field: bool | None = None,
        certify: SystemFactory | None = None,
        random: RecordingRandom | None = None,
        invariants: Sequence[Invariant | type | str] = (),
    ) -> None:
        if certify is not None and not isinstance(path, str | Path):
            raise ValueError("Recorder: certify replays the log, so it needs a path to read")
        if random is not None and seed is not None:
            raise ValueError("Recorder: give the seed to the random source, not both")
        self.period_ns = period_ns
        self._clock = clock
        self._last_beat_ns: int | None = None
        self.random = RecordingRandom(seed) if random is None else random
        setup_draws = self.random.take() or msgspec.UNSET
        self._executor = CycleExecutor(system, self.random)
        self._log_samples = log_samples
        self._overruns = 0
        self._warned = False
        self._close_error: OSError | None = None
        self._certify = certify
        self.certificate: Certificate | None = None
        """Whether the log replays against a fresh system, once the session ended, when
        asked for (``certify``)."""
        self._checker: InvariantChecker | None = None
        if invariants:  # replay's checker: the same invariants, the same cycles
            from beatlog.replay.invariants import InvariantChecker  # noqa: PLC0415

            self._checker = InvariantChecker(invariants, system)
        self.violations: list[Violation] = []
        """The invariants that did not hold as the session was recorded, in order (the
        first :data:`MAX_VIOLATIONS` kept)."""
        self._reported: set[str] = set()
        fields = state_fields(system.robot_state)
        header = SessionHeader(
            format_version=FORMAT_VERSION,
            beatlog_version=__version__,
            robot_id=robot_id,
            software_version=software if software is not None else software_version(),
            system=system_ref,
            period_ns=period_ns,
            start_time_ns=time.time_ns() if start_time_ns is None else start_time_ns,
            robot_state_type=state_type_name(system.robot_state),
            robot_state_schema=state_schema(system.robot_state),
            state_fields=fields
            if (by_field is None and len(fields) >= COLUMNS_FROM) or by_field
            else [],
            behaviors=list(self._executor.behavior_ids),
            initial_states=[behavior.state for behavior in system.behaviors.values()],
            random_seed=self.random.seed,
            setup_draws=setup_draws,
            samples_logged=log_samples,
            flush_interval_ns=int(flush_interval_s * 1e9),
            python_version=platform.python_version(),
        )
        self._writer = SessionLogWriter(
            path, header, overwrite=overwrite, flush_interval_s=flush_interval_s, fsync=fsync
        )
        self._encode = payload_encoder().encode
        self._as_logged = msgspec.msgpack.Decoder(system.robot_state).decode
        """RS_t as the log gives it back to replay: the behaviors see it live too, so a
        float32 or an int subclass, a tuple for a list, reaches them as replay hands it."""

    @property
    def cycles(self) -> int:
        """Cycles stepped so far."""
        return self._executor.context.cycle + 1

    @property
    def robot_time_ns(self) -> int:
        """Robot time so far: the sum of the heartbeat intervals."""
        return self._executor.clock.now_ns

    @property
    def overruns(self) -> int:
        """Heartbeats that came late: counted by :meth:`run`, or reported to :meth:`step`."""
        return self._overruns

    @property
    def error(self) -> str | None:
        """Why writing the log failed, if it did; the control loop is never stopped by it."""
        error = self._writer.error or self._close_error
        return None if error is None else f"{type(error).__name__}: {error}"

    def step(
        self,
        interval_ns: int,
        state: msgspec.Struct,
        samples: Sequence[Sample] = (),
        *,
        overrun: bool = False,
    ) -> Outputs:
        """Run one cycle with heartbeat interval HB_t and robot state RS_t; log it, never
        blocking on disk, and return the outputs the behaviors emitted. ``overrun``: this
        heartbeat came late (the end record counts them, as :meth:`run` does).

        The behaviors see ``state`` as replay will hand it to them, encoded and decoded
        back as its type (a ``numpy.float32`` becomes a ``float``); a state that does not
        decode as its type is refused by a :class:`~beatlog.errors.SchemaMismatchError`
        naming the field.
        """
        self._overruns += overrun
        executor = self._executor
        encoded = self._encode(state)
        try:
            logged = self._as_logged(encoded)
        except msgspec.ValidationError as exc:
            raise SchemaMismatchError(
                self._writer.path or "<output>",
                f"robot state of cycle {executor.context.cycle + 1} cannot be replayed as "
                f"{executor.system.robot_state.__name__}: {exc}",
            ) from None
        try:
            changes = executor.step(interval_ns, logged)
        except NumpyMissingError:
            raise NumpyMissingError(self._writer.path or "<output>") from None
        context = executor.context
        draws = self.random.take()
        self._writer.append(
            interval_ns,
            msgspec.Raw(encoded),
            changes,
            draws,
            context.outputs,
            samples if self._log_samples else (),
        )
        if self._checker is not None:
            cycle = self._checker.cycle(
                context.cycle,
                time_ns=context.time_ns,
                dt_ns=interval_ns,
                state=logged,
                changes=changes,
                outputs=context.outputs,
                draws=draws,
            )
            self._violated(self._checker.violated(cycle))
        if self._writer.error is not None and not self._warned:
            self._warned = True
            _log.error(
                "the log stopped being written (noticed at cycle %d): %s; the robot runs on",
                context.cycle,
                self.error,
            )
        return context.outputs

    def _violated(self, violations: list[Violation]) -> None:
        """Keep the violations of a cycle; log each invariant's first."""
        for violation in violations:
            if len(self.violations) < MAX_VIOLATIONS:
                self.violations.append(violation)
            if violation.invariant not in self._reported:
                self._reported.add(violation.invariant)
                _log.warning("%s; the robot runs on", violation)

    def beat(self, state: msgspec.Struct, samples: Sequence[Sample] = ()) -> Outputs:
        """Run one cycle of the robot's own loop with robot state RS_t; log it.

        The heartbeat interval HB_t is measured: the time on the recorder's ``clock``
        since the last beat (the first beat is one period long). A beat more than 1.5
        periods after the last counts as an overrun, as ``beatlog show`` counts late
        beats. Returns the outputs the behaviors emitted, as :meth:`step` does.
        """
        now_ns = self._clock()
        last_ns, self._last_beat_ns = self._last_beat_ns, now_ns
        interval_ns = self.period_ns if last_ns is None else now_ns - last_ns
        return self.step(interval_ns, state, samples, overrun=2 * interval_ns > 3 * self.period_ns)

    def run(
        self,
        robot: Robot,
        *,
        duration_s: float,
        heartbeat: LiveHeartbeat | None = None,
        on_cycle: Callable[[int], Any] | None = None,
    ) -> RecordSummary:
        """Run the robot in real time on a live heartbeat for ``duration_s`` of robot time.

        The robot's system must be the one this recorder was built with (the one its
        log describes); anything else is a programming error, refused loudly.
        """
        if robot.system is not self._executor.system:
            raise ValueError(
                "Recorder.run: the robot's system is not the one this recorder records; "
                "build the Recorder with robot.system"
            )
        clock = heartbeat or LiveHeartbeat(self.period_ns)
        until_ns = int(duration_s * 1e9)
        state: msgspec.Struct | None = None
        robot.start()
        try:
            clock.start()
            while self.robot_time_ns < until_ns:
                interval = clock.wait()
                samples = robot.inbox.drain()
                state = robot.perceive(state, samples)
                robot.act(self.step(interval, state, samples))
                if on_cycle is not None:
                    on_cycle(self.cycles)
        finally:
            robot.stop()
            self._overruns += clock.overruns
        return RecordSummary(self.cycles, self.robot_time_ns, clock.overruns, self.error)

    def close(self, *, error: str | None = None) -> None:
        """Close the log with its end record, which counts the cycles logged; a failure
        to write it is kept in :attr:`error`."""
        end = SessionEnd(
            cycles=self._writer.cycles_appended,
            robot_time_ns=self._writer.robot_time_ns,
            overruns=self._overruns,
            error=error,
        )
        try:
            self._writer.close(end)
        except OSError as exc:  # the file's last buffered bytes did not fit either
            self._close_error = exc
        certify, self._certify = self._certify, None  # once, however often it is closed
        if certify is not None and error is None and self.error is None:
            from beatlog.record.certify import certify as certified  # noqa: PLC0415 - replay

            assert self._writer.path is not None  # certify needs a path: checked when built
            self.certificate = certified(self._writer.path, certify)
            if not self.certificate.ok:
                _log.error("%s: %s", self._writer.path, self.certificate.describe())

    def __enter__(self) -> Recorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc is None:
            self.close()
        else:
            self.close(
                error="interrupted"
                if isinstance(exc, KeyboardInterrupt)
                else f"{type(exc).__name__}: {exc}"
            )
