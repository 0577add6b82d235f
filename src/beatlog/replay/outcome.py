"""What replaying one recorded cycle gives: its outcome, and why replay cannot go on past
it. Everything that consumes replay (the verdict, traces, timelines, the audit) reads
these; the replay core (:mod:`beatlog.replay.core`) makes them."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import msgspec

from beatlog.log.format import CycleRecord, LoggedStateChange
from beatlog.model.context import Outputs
from beatlog.model.cycle import actor_name
from beatlog.model.inbox import Sample
from beatlog.model.perception import perception_problem
from beatlog.model.random import Draw, plain_value
from beatlog.replay.draws import DrawMadeOtherwise
from beatlog.replay.random import RefusedDraw
from beatlog.replay.verdict import DivergenceKind, RandomDraw

__all__ = ["AGREED", "ByteCheck", "CycleOutcome", "Sensed", "Stop", "random_draws"]


AGREED: list[LoggedStateChange] = []
"""What :meth:`~beatlog.replay.core.Replayer.advance` answers for a cycle that replayed
the bytes expected of it (:class:`ByteCheck`): the one object, never another list."""


class ByteCheck(NamedTuple):
    """What a cycle must replay, byte for byte, to agree with its record at once: the
    verdict's hot path, in the replay core."""

    positions: list[int] | None
    """Each behavior's index in the expected catalogue (-1: none there), to encode the
    state changes as the record holds them; None where the catalogues are the same."""
    outputs: msgspec.msgpack.Encoder
    """How the record's outputs are encoded (a whole-trace baseline sorts their keys)."""
    judged: bool
    """Whether the verdict judges every cycle whole, whatever its bytes: it checks
    invariants in each, so none agrees at once."""
    draws: Callable[[int, Sequence[DrawMadeOtherwise]], bool] | None = None
    """In replay matching draws against a baseline, whether it approves a cycle's draws
    made otherwise than recorded, exactly (:meth:`~beatlog.replay.draws.DrawApprovals.approves`):
    a cycle that drew only as approved goes on to the byte comparison."""


class CycleOutcome(NamedTuple):
    """What happened when the system replayed one recorded cycle."""

    cycle: int
    time_ns: int
    """Robot time at the end of the cycle."""
    record: CycleRecord
    """The recorded cycle: HB_t, RS_t, BS_t, RN_t and outputs, still encoded (RS_t
    decoded where the reader decoded it with the batch)."""
    state: Any
    """RS_t as the behaviors saw it."""
    changes: list[LoggedStateChange] | None
    """BS'_t, the replayed state changes; None when the update did not complete."""
    outputs: Outputs
    """The replayed outputs (as far as the update got)."""
    recorded_draws: Sequence[Draw]
    drawn: Sequence[Draw]
    """The random numbers the behaviors drew, with what they asked for; a draw refused
    as not the one recorded is the last, with no value."""
    refused_draw: RefusedDraw | None
    """A draw that did not match the recording (another kind or request, or one too many)."""
    failure: BaseException | None
    """What the behavior code raised (including ``SystemExit``), if it did."""
    actor: int
    """The behavior that was running when the update stopped (-1: the system itself)."""
    recorded_state: Any = None
    """In sensor-level replay, RS_t as recorded (``state`` is the rebuilt one)."""
    perception_differs: bool = False
    """In sensor-level replay, whether the rebuilt RS_t differs from the recorded one."""
    perception_failure: BaseException | None = None
    """What the perception step raised, if it did (the behaviors then ran on the
    recorded RS_t, so replay can go on)."""
    samples: Sequence[Sample] = ()
    """In sensor-level replay, the samples of the cycle."""
    draws_otherwise: Sequence[DrawMadeOtherwise] | None = None
    """In replay matching draws (:meth:`~beatlog.replay.random.ReplayRandom.match_draws`),
    the draws made otherwise than recorded, which replay went on with; None in strict
    replay."""

    @property
    def completed(self) -> bool:
        """Whether the update ran to its end and, in strict replay, drew exactly the
        recorded numbers."""
        return (
            self.changes is not None
            and self.refused_draw is None
            and (self.draws_otherwise is not None or len(self.drawn) == len(self.recorded_draws))
        )

    def stop(self, names: Sequence[str], recorded_names: Sequence[str]) -> Stop | None:
        """Why replay cannot go on past this cycle, if it cannot: perception failed, a
        behavior raised, a draw was not the one recorded (or one too many), or fewer
        random numbers were drawn than recorded. ``names`` are the behaviors' names now,
        ``recorded_names`` the recording's catalogue."""
        if self.perception_failure is not None:
            problem = perception_problem(self.perception_failure)
            return Stop(DivergenceKind.PERCEPTION, problem, None)
        if self.failure is not None:
            behavior = actor_name(names, self.actor)
            failure = self.failure
            message = f"{behavior} raised {type(failure).__name__}: {failure}"
            return Stop(DivergenceKind.EXCEPTION, message, behavior)
        refused = self.refused_draw
        if refused is not None:
            kind = (
                DivergenceKind.RANDOM_OVERDRAWN
                if refused.overdrawn
                else DivergenceKind.RANDOM_MISMATCH
            )
            behavior = actor_name(names, refused.actor)
            return Stop(kind, f"{behavior} {refused.problem}", behavior)
        if self.draws_otherwise is None and len(self.drawn) < len(self.recorded_draws):
            drawn, recorded = len(self.drawn), len(self.recorded_draws)
            missing = self.recorded_draws[drawn]
            behavior = actor_name(recorded_names, missing.actor)
            message = (
                f"drew {drawn} random numbers where {recorded} were recorded; the next "
                f"recorded one was a {missing.kind} drawn by {behavior}"
            )
            return Stop(DivergenceKind.RANDOM_UNDERDRAWN, message, behavior)
        return None


class Stop(NamedTuple):
    """Why replay cannot go on past a cycle: the one classification of it, which the
    verdict headlines and a whole-session trace stops at."""

    kind: DivergenceKind
    message: str
    """What happened, naming the behavior: ``dice raised ZeroDivisionError: ...``."""
    behavior: str | None
    """The behavior it concerns (None for a perception step that failed)."""


class Sensed(NamedTuple):
    """What sensor-level replay adds to a cycle's outcome."""

    recorded_state: Any
    differs: bool
    failure: BaseException | None
    samples: Sequence[Sample]


def random_draws(draws: Sequence[Draw], names: Sequence[str]) -> list[RandomDraw]:
    """Draws as reports show them, each by the name (of ``names``) of the behavior that drew it."""
    return [
        RandomDraw(actor_name(names, d.actor), d.kind, plain_value(d), d.call() if d.params else "")
        for d in draws
    ]
