"""The replay engine (the paper's Algorithm 2): run a system on a session log and judge it.

For each cycle t it advances a simulated clock by HB_t (never waiting), loads RS_t,
updates the behaviors with RN_t as their random numbers and compares the behavior
state changes and outputs with the recorded ones, byte for byte.
"""

from __future__ import annotations

import shlex
import time
import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import msgspec

from beatlog.engine.cycle import CycleExecutor, StateChangeRecord
from beatlog.engine.loading import load_system
from beatlog.engine.verdict import (
    Divergence,
    DivergenceKind,
    DrawReport,
    ReplayResult,
    StateChange,
)
from beatlog.errors import BeatlogError, CorruptLogError, SchemaMismatchError
from beatlog.log.format import (
    EMPTY_LIST,
    EMPTY_MAP,
    CycleRecord,
    SessionHeader,
    payload_encoder,
)
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import System
from beatlog.model.random import Draw, RandomMismatch, ReplayRandom

__all__ = ["replay"]

_PACKAGE_DIR = str(Path(__file__).parent.parent)
_EXAMPLES_DIR = str(Path(__file__).parent.parent / "examples")


def replay(
    log: str | Path,
    system: System | str,
    *,
    keep_going: bool = False,
    allow_truncated: bool = False,
) -> ReplayResult:
    """Replay ``log`` against ``system`` (a system, or a ``module:factory`` reference).

    Stops at the first divergence unless ``keep_going`` is set, in which case it
    replays every cycle and counts the ones that diverged. A truncated log fails
    with a LOG_ENDED divergence after its last complete cycle unless
    ``allow_truncated`` is set.

    :raises beatlog.errors.LogError: the log is missing, foreign, corrupt or its robot
        state does not fit the system's robot state type.
    """
    reference = system if isinstance(system, str) else None
    if isinstance(system, str):
        system = load_system(system)
    with SessionLogReader(log) as reader:
        judge = _Judge(reader.header, system, reader.path, keep_going=keep_going)
        started = time.perf_counter()
        status = None
        for batch in reader.batches():
            if judge.run(batch):
                break
        else:
            status = reader.status
            if not status.complete and not allow_truncated:
                judge.log_ended(status.describe())
        wall = time.perf_counter() - started
    executor = judge.executor
    return ReplayResult(
        log=Path(log),
        ok=judge.divergence is None,
        cycles=executor.context.cycle + 1,
        robot_time_ns=executor.clock.now_ns,
        wall_time_s=wall,
        status=status,
        divergence=judge.divergence,
        divergent_cycles=judge.divergent_cycles,
        reproduce=_reproduce_command(Path(log), reference or reader.header.system),
    )


def _reproduce_command(log: Path, reference: str) -> str:
    reference = reference or "MODULE:FACTORY"
    return f"beatlog replay {shlex.quote(str(log))} --system {shlex.quote(reference)}"


class _Judge:
    """Replays cycles and keeps the first divergence; the hot loop lives in :meth:`run`."""

    def __init__(
        self, header: SessionHeader, system: System, path: Path, *, keep_going: bool
    ) -> None:
        self.header = header
        self._keep_going = keep_going
        self.path = path
        self.random = ReplayRandom()
        self.executor = CycleExecutor(system, self.random)
        self.divergence: Divergence | None = None
        self.divergent_cycles = 0
        self._same_catalogue = self.executor.behavior_ids == header.behaviors
        self._state_decoder = msgspec.msgpack.Decoder(system.robot_state)
        self._draws_decoder = msgspec.msgpack.Decoder(list[Draw])
        self._changes_decoder = msgspec.msgpack.Decoder(list[StateChangeRecord])
        self._outputs_decoder = msgspec.msgpack.Decoder(dict[str, Any])
        self._encoder = payload_encoder()

    def run(self, batch: Sequence[CycleRecord]) -> bool:
        """Replay a batch of cycles; True when replay should stop at a divergence."""
        encode = self._encoder.encode
        random = self.random
        step = self.executor.step
        context = self.executor.context
        same_catalogue = self._same_catalogue
        raw = msgspec.Raw
        for record in batch:
            state = self._state(record)
            random.load(() if record.rn == EMPTY_LIST else self._draws(record.rn))
            changes: list[StateChangeRecord] | None = None
            failure: Exception | None = None
            try:
                changes = step(record.hb_ns, state)
                if (
                    random.mismatch is None
                    and len(random.drawn) == len(random.recorded)
                    and (
                        (
                            record.bs == EMPTY_LIST
                            if not changes
                            else record.bs == raw(encode(changes))
                        )
                        if same_catalogue
                        else self._named(record.bs) == self._named_actual(changes)
                    )
                    and (
                        record.out == EMPTY_MAP
                        if not context.outputs
                        else record.out == raw(encode(context.outputs))
                    )
                ):
                    continue
            except RandomMismatch:
                pass
            except BeatlogError:
                raise
            except Exception as exc:  # behavior code failing is a verdict, not a crash
                failure = exc
            self._diverge(record, state, changes, failure)
            if not self._keep_going:
                return True
        return False

    def _state(self, record: CycleRecord) -> Any:
        try:
            return self._state_decoder.decode(record.rs)
        except msgspec.DecodeError as exc:
            raise SchemaMismatchError(
                self.path,
                f"robot state of cycle {self.executor.context.cycle + 1} does not fit "
                f"{self.executor.system.robot_state.__name__}: {exc}",
            ) from None

    def _decode(self, data: msgspec.Raw, decode: Any, what: str) -> Any:
        try:
            return decode(data)
        except msgspec.DecodeError as exc:
            raise CorruptLogError(
                self.path, f"damaged {what} in cycle {self.executor.context.cycle}: {exc}"
            ) from None

    def _draws(self, data: msgspec.Raw) -> list[Draw]:
        return self._decode(data, self._draws_decoder.decode, "random numbers")  # type: ignore[no-any-return]

    def log_ended(self, why: str) -> None:
        """Record that the log stopped before the recording closed it."""
        context = self.executor.context
        if self.divergence is None:
            self.divergence = Divergence(
                kind=DivergenceKind.LOG_ENDED,
                cycle=context.cycle + 1,
                time_ns=context.time_ns,
                message=f"the log ends early ({why})",
            )
        self.divergent_cycles += 1

    def _named(self, raw_changes: msgspec.Raw) -> list[StateChange]:
        names = self.header.behaviors
        recorded = self._decode(raw_changes, self._changes_decoder.decode, "state changes")
        return [
            StateChange(_name(names, index), before, after) for index, before, after in recorded
        ]

    def _named_actual(self, changes: list[StateChangeRecord]) -> list[StateChange]:
        names = self.executor.behavior_ids
        return [StateChange(names[index], before, after) for index, before, after in changes]

    def _actor_name(self, actor: int) -> str:
        return "system" if actor < 0 else self.executor.behavior_ids[actor]

    def _diverge(
        self,
        record: CycleRecord,
        state: msgspec.Struct,
        changes: list[StateChangeRecord] | None,
        exc: BaseException | None = None,
    ) -> None:
        self.divergent_cycles += 1
        if self.divergence is not None:
            return
        context = self.executor.context
        random = self.random
        expected = self._named(record.bs)
        actual = self._named_actual(changes or [])
        expected_outputs = self._decode(record.out, self._outputs_decoder.decode, "outputs")
        mismatch = random.mismatch
        behavior: str | None = None
        trace: str | None = None
        if exc is not None:
            kind = DivergenceKind.EXCEPTION
            behavior = self._actor_name(context.actor)
            trace = _user_traceback(exc)
            message = f"{behavior} raised {type(exc).__name__}: {exc}"
        elif mismatch is not None:
            kind = (
                DivergenceKind.RANDOM_OVERDRAWN
                if mismatch.overdrawn
                else DivergenceKind.RANDOM_MISMATCH
            )
            behavior = self._actor_name(mismatch.actor)
            message = f"{behavior} {mismatch.problem}"
        elif len(random.drawn) < len(random.recorded):
            kind = DivergenceKind.RANDOM_UNDERDRAWN
            missing = random.recorded[len(random.drawn)]
            behavior = self._actor_name(missing.actor)
            message = (
                f"drew {len(random.drawn)} random numbers where {len(random.recorded)} were "
                f"recorded; the next recorded one was a {missing.kind} drawn by {behavior}"
            )
        elif expected != actual:
            kind = DivergenceKind.STATE_CHANGES
            message = "behavior state changes differ from the recording"
            behavior = _first_differing_behavior(expected, actual)
        else:
            kind = DivergenceKind.OUTPUTS
            message = "outputs differ from the recording"
        self.divergence = Divergence(
            kind=kind,
            cycle=context.cycle,
            time_ns=context.time_ns,
            message=message,
            behavior=behavior,
            expected=tuple(expected),
            actual=tuple(actual),
            expected_outputs=expected_outputs,
            actual_outputs=dict(context.outputs) if exc is None and mismatch is None else {},
            robot_state=msgspec.to_builtins(state),
            random_recorded=tuple(self._reports(random.recorded, self.header.behaviors)),
            random_drawn=tuple(self._reports(random.drawn, self.executor.behavior_ids)),
            traceback=trace,
        )

    def _reports(self, draws: Sequence[Draw], names: Sequence[str]) -> list[DrawReport]:
        return [DrawReport(_name(names, d.actor), d.kind, d.value) for d in draws]


def _name(names: Sequence[str], index: int) -> str:
    if index < 0:
        return "system"
    return names[index] if index < len(names) else f"#{index}"


def _first_differing_behavior(
    expected: Sequence[StateChange], actual: Sequence[StateChange]
) -> str | None:
    for want, got in zip(expected, actual, strict=False):
        if want != got:
            return want.behavior
    longer = expected if len(expected) > len(actual) else actual
    shorter = min(len(expected), len(actual))
    return longer[shorter].behavior if len(longer) > shorter else None


def _user_traceback(exc: BaseException) -> str:
    """The traceback with beatlog's own frames left out, so it starts in the user's code."""
    frames = [
        frame
        for frame in traceback.extract_tb(exc.__traceback__)
        if not frame.filename.startswith(_PACKAGE_DIR) or frame.filename.startswith(_EXAMPLES_DIR)
    ]
    lines = ["Traceback (most recent call last):\n", *traceback.format_list(frames)]
    lines.extend(traceback.format_exception_only(exc))
    return "".join(lines)
