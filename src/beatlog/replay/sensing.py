"""Sensor-level replay: each cycle's robot state rebuilt from its logged samples by the
perception step, and compared with the one expected (the recorded RS_t, or the one an
approved baseline approves). The replay core (:mod:`beatlog.replay.core`) runs it in the
cycles of a log that holds samples."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import msgspec

from beatlog.errors import BeatlogError
from beatlog.log.format import CycleRecord
from beatlog.model.perception import Perception, PerceptionTypeError
from beatlog.replay.approved_states import ApprovedStateChecker
from beatlog.replay.cycle_reader import CycleReader
from beatlog.replay.outcome import Sensed

__all__ = ["UNREAD", "Perceiver"]

UNREAD: Any = object()
"""In place of a recorded RS_t not decoded yet (sensor-level replay decodes it only
where it is needed)."""


class Perceiver:
    """Rebuilds each cycle's robot state with ``perception``, from the state it rebuilt
    last and the cycle's samples, and says whether it differs from the one expected.

    ``approved_states`` are the robot states an approved baseline holds by digest: in their
    cycles the rebuilt state is judged against them, not the recorded one. ``migrated``
    says the log recorded RS_t under other names or types than ``robot_state``'s, so
    that the same state holds other bytes.
    """

    def __init__(
        self,
        perception: Perception,
        robot_state: type,
        reader: CycleReader,
        encode: Callable[[Any], bytes],
        *,
        approved_states: ApprovedStateChecker | None,
        migrated: bool,
    ) -> None:
        self.perception = perception
        self.rebuilt: Any = None
        """The robot state rebuilt last, as perception built it: perception is given it
        with the next cycle's samples."""
        self.seen: Any = None
        """The robot state rebuilt last as the log would store it (encoded, and decoded
        back as its type): the behaviors see it, as they see RS_t when it is recorded
        (:meth:`~beatlog.record.recorder.Recorder.step`)."""
        self._as_logged: Callable[[bytes], Any] = msgspec.msgpack.Decoder(robot_state).decode
        self.samples_perceived = 0
        """The samples the perception step was given so far, every cycle's."""
        self._robot_state = robot_state
        self._reader = reader
        self._encode = encode
        self._approved_states = approved_states or ApprovedStateChecker()
        self._migrated = migrated

    def perceive(self, record: CycleRecord, recorded: Any, cycle: int) -> Sensed:
        """Rebuild RS_t of ``cycle`` (kept as :attr:`rebuilt`) and compare it;
        ``recorded`` is the recorded RS_t, or :data:`UNREAD`.

        When perception raises, or returns something other than the system's robot
        state (a :class:`PerceptionTypeError`), the behaviors run on the recorded RS_t,
        so replay can go on; the outcome carries the failure.
        """
        samples = self._reader.samples(record, cycle)
        self.samples_perceived += len(samples)
        try:
            rebuilt = self.perception(self.rebuilt, samples)
            if not isinstance(rebuilt, self._robot_state):
                raise PerceptionTypeError(rebuilt, self._robot_state)
        except BeatlogError:
            raise
        except (Exception, SystemExit) as exc:  # perception failing is an outcome
            if recorded is UNREAD:
                recorded = self._reader.recorded_state(record, cycle)
            self.rebuilt = self.seen = recorded
            return Sensed(recorded, False, exc, samples)
        self.rebuilt = self.seen = rebuilt
        try:
            encoded = self._encode(rebuilt)
            self.seen = self._as_logged(encoded)
        except (TypeError, msgspec.EncodeError, msgspec.ValidationError):
            encoded = None  # perception built something unloggable, or not as its type
        if cycle in self._approved_states:  # the approved state is expected
            differs = encoded is None or self._approved_states.mismatch(cycle, encoded) is not None
        else:
            differs = encoded is None or msgspec.Raw(encoded) != record.robot_state
            if differs and encoded is not None and self._migrated:
                # Recorded under other names or types: the same state holds other bytes.
                if recorded is UNREAD:
                    recorded = self._reader.recorded_state(record, cycle)
                differs = encoded != self._encode(recorded)
        if differs and recorded is UNREAD:
            recorded = self._reader.recorded_state(record, cycle)
        return Sensed(recorded, differs, None, samples)
