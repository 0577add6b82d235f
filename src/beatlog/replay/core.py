"""The replay core: the one place that steps a system through a session log.

For each recorded cycle t it decodes RS_t (or, in sensor-level replay, rebuilds it from
the cycle's samples and compares it with the recorded one), loads RN_t into the random
source, advances the simulated clock by HB_t and updates the behaviors, then hands back
a :class:`~beatlog.replay.outcome.CycleOutcome` with everything anyone needs. The
verdict, traces, timelines and the audit all consume these outcomes.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import msgspec

from beatlog.errors import BeatlogError, NumpyMissingError
from beatlog.log.columns import StateColumns
from beatlog.log.format import (
    EMPTY_LIST,
    EMPTY_MAP,
    CycleRecord,
    LoggedStateChange,
    SessionHeader,
    payload_encoder,
)
from beatlog.model.behavior import System
from beatlog.model.cycle import CycleExecutor, actor_name
from beatlog.model.perception import Perception
from beatlog.replay.approved_states import ApprovedStateChecker
from beatlog.replay.cycle_reader import CycleReader
from beatlog.replay.draws import log_key
from beatlog.replay.fit.check import check_fit
from beatlog.replay.fit.migration import StateConverter, StateMigration
from beatlog.replay.fit.schema import recorded_state_type
from beatlog.replay.outcome import AGREED, ByteCheck, CycleOutcome, Sensed, Stop
from beatlog.replay.random import RefusedDraw, ReplayRandom
from beatlog.replay.sensing import UNREAD, Perceiver
from beatlog.replay.view import StateViews

__all__ = ["AGREED", "ByteCheck", "CycleOutcome", "Replayer", "Stop"]


Observe = Callable[[Any], Any]


class Replayer:
    """A system set up to replay the cycles of one log, in order, from its first.

    Building one checks that the log fits the system (:mod:`beatlog.replay.fit`), its
    robot-state fields renamed and converted by ``migration``, and imports the
    migration's conversions. Given a ``perception`` and a log recorded with its samples,
    RS_t is rebuilt from the samples (sensor-level replay). Each cycle must hold what the
    header declares, or it is a :class:`~beatlog.errors.LogError` naming the cycle, after
    which the replayer cannot go on.

    :meth:`advance` replays a cycle and says only whether it went cleanly, all the
    verdict needs of a cycle that matches; :meth:`outcome` tells everything about it.
    """

    def __init__(
        self,
        system: System,
        header: SessionHeader,
        path: Path,
        *,
        perception: Perception | None = None,
        break_at: int | None = None,
        match_draws: bool = False,
        rename: Callable[[str], str] = str,
        migration: StateMigration | None = None,
        approved_states: ApprovedStateChecker | None = None,
        random: ReplayRandom | None = None,
    ) -> None:
        migration = migration or StateMigration()
        check_fit(header, system, path, migration)
        self.state_type = recorded_state_type(header, system.robot_state, migration)
        """The system's robot state type as each cycle's RS_t must hold it: decode RS_t
        with it (:meth:`~beatlog.log.reader.SessionLogReader.decode_states`); the
        behaviors get each as an instance of the system's type itself."""
        self.break_at = break_at
        """Stop in the debugger just before the behaviors update in this cycle."""
        self.system = system
        self.header = header
        self.path = path
        self.random = ReplayRandom() if random is None else random
        """The random source: ``random``, the one the system drew its set-up from, if given."""
        self.executor = CycleExecutor(system, self.random)
        self.match_draws = match_draws
        """Whether replay goes on when the behaviors draw otherwise than recorded
        (:meth:`~beatlog.replay.random.ReplayRandom.match_draws`); ``rename`` maps a recorded
        behavior's name to its name now, matching each behavior's draws."""
        if match_draws:
            self.random.expect_actors(header.behaviors, self.executor.behavior_ids, rename)
            self.random.match_draws(log_key(header))
        self.perception = perception if header.samples_logged else None
        """The perception step in use: None unless the log holds samples."""
        self.approved_states = approved_states
        """The robot states an approved baseline pins by digest: in their cycles the
        rebuilt state is judged against them, not the recorded one."""
        self._encode = payload_encoder().encode
        convert = StateConverter(system.robot_state, migration) if migration.converted() else None
        self._views = StateViews(system.robot_state, self.state_type, path, convert)
        """RS_t of a format-3 log: views that decode only the fields read."""
        self._reader = CycleReader(header, path, self._views)
        """The log's cycle records, read and checked as the header declares them."""
        self._perceiver = (
            None
            if self.perception is None
            else Perceiver(
                self.perception,
                system.robot_state,
                self._reader,
                self._encode,
                approved_states=approved_states,
                migrated=bool(migration),
            )
        )
        self.observe: Observe | None = None
        """What wraps RS_t before the behaviors see it while set (e.g. a stand-in that
        notes the fields read); the outcome holds the state it wraps."""
        self.perturb: Observe | None = None
        """What takes the place of RS_t before the behaviors see it while set (a
        variant's noise); the outcome holds what the behaviors saw."""
        self._last: tuple[
            CycleRecord, Any, list[LoggedStateChange] | None, BaseException | None, Sensed | None
        ]
        self._check: ByteCheck | None = None
        self.agreed = [0, 0, 0]
        """What the cycles that agreed at once (:meth:`check_bytes`) held: state changes,
        outputs and draws."""

    @property
    def samples_perceived(self) -> int:
        """The samples the perception step was given so far, every cycle's."""
        return 0 if self._perceiver is None else self._perceiver.samples_perceived

    def check_bytes(self, check: ByteCheck) -> None:
        """Before the first cycle: compare each cycle that goes cleanly with its
        record, byte for byte, and answer :data:`AGREED` where they agree."""
        self._check = check

    def agrees(self, record: CycleRecord, changes: list[LoggedStateChange]) -> bool:
        """Whether ``changes`` and the outputs of the cycle replayed last are the bytes
        its ``record`` expects (:meth:`check_bytes`): each cycle's check.

        :raises msgspec.EncodeError: they cannot be logged (or a ``TypeError`` or
            ``ValueError`` from an encoding hook).
        """
        assert self._check is not None  # only a byte check says what agrees
        positions = self._check.positions
        outputs = self.executor.context.outputs
        return (
            record.state_changes == EMPTY_LIST
            if not changes
            else record.state_changes
            == msgspec.Raw(
                self._encode(
                    changes if positions is None else [(positions[i], b, a) for i, b, a in changes]
                )
            )
        ) and (
            record.outputs == EMPTY_MAP
            if not outputs
            else record.outputs == msgspec.Raw(self._check.outputs.encode(outputs))
        )

    def outcome(self) -> CycleOutcome:
        """Everything about the cycle replayed last."""
        record, state, changes, failure, sensed = self._last
        context = self.executor.context
        random = self.random
        outcome = CycleOutcome(
            context.cycle,
            context.time_ns,
            record,
            state,
            changes,
            context.outputs,
            random.recorded,
            random.drawn,
            random.refused,
            failure,
            context.actor,
            draws_otherwise=tuple(random.made_otherwise) if self.match_draws else None,
        )
        if sensed is None:
            return outcome
        recorded = sensed.recorded_state  # decoded here when it matched the rebuilt one
        return outcome._replace(
            recorded_state=(
                self._reader.recorded_state(record, context.cycle)
                if recorded is UNREAD
                else recorded
            ),
            perception_differs=sensed.differs,
            perception_failure=sensed.failure,
            samples=sensed.samples,
        )

    @property
    def raised(self) -> BaseException | None:
        """What the behavior code (or, first, the perception step) raised in the cycle
        replayed last, if it raised: :meth:`outcome` tells more, at a cost."""
        sensed = self._last[4]
        return self._last[3] if sensed is None or sensed.failure is None else sensed.failure

    @property
    def stepped(self) -> list[LoggedStateChange] | None:
        """BS'_t of the cycle replayed last where its update completed, whether or not it
        drew as recorded (:meth:`advance` answers None for a cycle that drew otherwise);
        None where it did not complete."""
        return self._last[2]

    def stop(self, outcome: CycleOutcome) -> Stop | None:
        """Why replay cannot go on past ``outcome``'s cycle, if it cannot
        (:meth:`~beatlog.replay.outcome.CycleOutcome.stop`)."""
        return outcome.stop(self.executor.behavior_ids, self.header.behaviors)

    def advance(  # noqa: PLR0915 - one cycle's replay, step by step
        self,
        record: CycleRecord,
    ) -> list[LoggedStateChange] | None:
        """Replay the next cycle, ``record``'s: BS'_t, the replayed state changes, when it
        went cleanly (the update completed, drew as recorded and, in sensor-level replay,
        ran on a robot state rebuilt as recorded), else None; :data:`AGREED` where it also
        replayed the bytes expected of it (:meth:`check_bytes`).

        :raises beatlog.errors.LogError: RS_t or RN_t is damaged or does not fit.
        """
        executor = self.executor
        context = executor.context
        random = self.random
        perceiver = self._perceiver
        cycle = context.cycle + 1
        state: Any = UNREAD
        # Sensor-level replay decodes the recorded RS_t only where it is needed: the
        # rebuilt one encodes to other bytes, perception fails, or a break. A sensor-level
        # replay of the dog's wall-follow takes 6.0 % fewer instructions than decoding it
        # every cycle (334.5 M against 356.0 M, cachegrind).
        if perceiver is None or cycle == self.break_at:
            state = record.robot_state  # decoded with the batch, or still bytes
            kind = state.__class__
            if kind is msgspec.Raw:
                state = self._reader.state(record, cycle)
            elif kind is StateColumns:  # format 3 by field: a view of the batch's columns
                state = self._views.view(state, cycle)
            elif kind is self.state_type and kind is not self.system.robot_state:
                # decoded as the checking subclass: made the system's, its fields
                # converted where a migration converts them
                self._views.adopt(state, cycle)
        if cycle == self.break_at:
            self._pause(cycle, state, record)
        if perceiver is None:
            sensed = None
        else:
            sensed = perceiver.perceive(record, state, cycle)
            state = perceiver.seen
        draws = record.random_numbers
        # Load RN_t, unless there is none and nothing is left of the last cycle's (a draw
        # is kept only when one was recorded; a draw too many leaves a mismatch).
        if draws != EMPTY_LIST or random.recorded or random.drawn or random.refused is not None:
            random.load(() if draws == EMPTY_LIST else self._reader.draws(record, cycle))
        if self.perturb is not None:
            state = self.perturb(state)
        failure = None
        changes: list[LoggedStateChange] | None
        try:
            changes = executor.step(
                record.heartbeat_ns, state if self.observe is None else self.observe(state)
            )
        except RefusedDraw:
            changes = None
        except NumpyMissingError:
            raise NumpyMissingError(self.path) from None
        except BeatlogError:
            raise
        except (Exception, SystemExit) as exc:  # behavior code failing is an outcome
            changes = None
            failure = exc
        self._last = (record, state, changes, failure, sensed)
        check = self._check
        if random.refused is not None:
            drew_otherwise = True
        elif self.match_draws:
            # a cycle that neither drew nor had draws recorded has none to settle
            differences = random.settle() if random.recorded or random.drawn else ()
            drew_otherwise = bool(differences) and not (
                check is not None
                and check.draws is not None
                and check.draws(context.cycle, differences)
            )
        else:
            drew_otherwise = len(random.drawn) != len(random.recorded)
        if changes is None or drew_otherwise:
            return None
        if sensed is not None and (sensed.differs or sensed.failure is not None):
            return None
        if check is None or check.judged:
            return changes
        try:
            if not self.agrees(record, changes):
                return changes
        except (TypeError, ValueError, msgspec.EncodeError):
            return changes  # cannot be logged: the verdict says so
        self.agreed[0] += len(changes)
        self.agreed[1] += len(context.outputs)
        self.agreed[2] += len(random.recorded)  # an agreeing cycle drew them all
        return AGREED

    def _pause(self, cycle: int, robot_state: Any, record: CycleRecord) -> None:
        """The replay debugger: stop in ``cycle`` just before the behaviors update, once
        the context is the cycle's (:func:`beatlog.replay.debugger.pause`), with
        ``robot_state`` (RS_t as recorded), BS_t and RN_t at hand."""
        from beatlog.replay.debugger import pause  # noqa: PLC0415 - pdb only for a break

        names = self.header.behaviors
        recorded_changes = [
            (actor_name(names, index), before, after)
            for index, before, after in msgspec.msgpack.decode(record.state_changes)
        ]
        recorded_draws = (
            [] if record.random_numbers == EMPTY_LIST else self._reader.draws(record, cycle)
        )
        self.executor.pause_next_update(
            functools.partial(
                pause,
                system=self.system,
                log=self.path,
                recorded_state=robot_state,
                recorded_changes=recorded_changes,
                recorded_draws=recorded_draws,
            )
        )
