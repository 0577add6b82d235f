"""The verdict as an observer of a replay session: compare each cycle's state changes
and outputs with the expected ones, byte for byte first, and by the spec's comparison
only when the bytes differ (:mod:`beatlog.replay.judge` runs it over a log)."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import msgspec

from beatlog.errors import CorruptLogError
from beatlog.log.format import (
    CycleRecord,
    StateChangeRecord,
    payload_encoder,
)
from beatlog.log.payload import decode_outputs, decode_part, decode_state_changes
from beatlog.replay.compare import Comparison
from beatlog.replay.core import CycleOutcome, Expected, Replayer
from beatlog.replay.divergences import Divergences, Follower
from beatlog.replay.draws import DrawLedger
from beatlog.replay.expectation import Expectation
from beatlog.replay.expected import ExpectedRecords
from beatlog.replay.fit import check_catalogue
from beatlog.replay.verdict import Checked, Divergence, StateChange

__all__ = ["CycleJudge"]


class CycleJudge:
    """Judges the cycles a replay session steps and keeps the first divergence: the
    session's :class:`~beatlog.replay.session.Judge`, whose :attr:`judge` is the hot path.

    ``expected`` is an approved baseline to judge against instead of the recording.
    Past the divergence where it stops, a :class:`Follower` gathers what happened next.
    """

    def __init__(
        self,
        replayer: Replayer,
        *,
        keep_going: bool,
        context: int,
        comparison: Comparison,
        expected: Expectation | None,
    ) -> None:
        header, path = replayer.header, replayer.path
        self.comparison = comparison
        self._keep_going = keep_going
        self.path = path
        self.replayer = replayer
        check_catalogue(header, replayer.system, path, comparison.renames)
        replayer.random.expect_actors(
            header.behaviors, replayer.executor.behavior_ids, comparison.rename
        )
        self.executor = replayer.executor
        self._stopped_at: tuple[int, int] | None = None
        self._samples_perceived = 0
        """The replay core's count of samples perceived, where judging stopped or ended."""
        self._follower: Follower | None = None
        """What follows replay past the divergence where judging stopped."""
        encoder = payload_encoder()
        self._expected = (
            None
            if expected is None or expected.as_recorded
            else ExpectedRecords(
                expected, self.executor.behavior_ids, header.behaviors, comparison.rename
            )
        )
        self.expected_names = (
            list(header.behaviors) if self._expected is None else self._expected.names
        )
        ledger = None if expected is None else DrawLedger(expected.draws)
        pinned_states: dict[int, dict[str, Any]] = {}
        """The robot states a format 3 baseline pins: fields by cycle (sensor-level replay)."""
        if expected is not None and replayer.perception is not None:
            pinned_states = expected.states_by_cycle()
        self._pinned_cycles = frozenset(pinned_states)
        """The cycles a format 3 baseline pins (the replay core judges the cycles pinned
        by digest)."""
        # Whole-trace outputs are encoded with sorted keys, whatever order the behaviors
        # report them in; recorded ones (and departures') in the order they were reported.
        self._outputs_encoder = (
            msgspec.msgpack.Encoder(enc_hook=encoder.enc_hook, order="sorted")
            if self._expected is not None and self._expected.sorted_outputs
            else encoder
        )
        self._same_catalogue = self.executor.behavior_ids == self.expected_names
        expected_at: dict[str, int] = {}
        for position, name in enumerate(self.expected_names):
            expected_at.setdefault(comparison.rename(name), position)
        self._expected_index = [expected_at.get(name, -1) for name in self.executor.behavior_ids]
        """Each behavior's index in the expected catalogue (-1: none there), for comparing
        the state changes as bytes when the catalogues differ."""
        self.divergences = Divergences(
            replayer,
            comparison,
            context=context,
            keep_going=keep_going,
            named=self._named,
            outputs_of=self._expected_outputs,
            expected_names=self.expected_names,
            ledger=ledger,
            pinned_states=pinned_states,
            against=(self._against(), self._outputs_against()),
        )
        self._changes_checked = self._outputs_checked = self._draws_checked = 0
        """The state changes, outputs and draws of the cycles that agreed here (those
        that agreed at once the replay core counts)."""
        replayer.expect(
            Expected(
                None if self._same_catalogue else self._expected_index,
                self._outputs_encoder,
                self._pinned_cycles,
                None if ledger is None else ledger.approves,
            )
        )

    def batches(self, batches: Iterator[Sequence[CycleRecord]]) -> Iterator[Sequence[CycleRecord]]:
        """The log's batches, with an approved baseline's state changes and outputs in
        place of the recorded ones where it expects others; each kept for the cycles
        before a divergence as it is handed on."""
        if self._expected is not None:
            batches = self._expected.batches(batches, self.path)
        for batch in batches:
            self.divergences.remember(batch)
            yield batch

    def _against(self) -> str:
        """What replay is judged against, for messages."""
        return "the recording" if self._expected is None else "the approved baseline"

    def _outputs_against(self) -> str:
        """What the outputs are judged against, for messages."""
        if self._expected is None:
            return "the recording"
        if not self._expected.pins_outputs:
            return "the recording (the approved baseline pins no outputs: re-approve it)"
        return "the approved baseline"

    @property
    def divergence(self) -> Divergence | None:
        """The first divergence, if any."""
        return self.divergences.divergence

    @property
    def divergent_cycles(self) -> int:
        """The cycles that diverged."""
        return self.divergences.divergent_cycles

    @property
    def cycles(self) -> int:
        """Cycles judged: up to the divergence that stopped replay, or all of them."""
        return self._stopped_at[0] if self._stopped_at else self.executor.context.cycle + 1

    @property
    def robot_time_ns(self) -> int:
        """Robot time judged, matching :attr:`cycles`."""
        return self._stopped_at[1] if self._stopped_at else self.executor.clock.now_ns

    @property
    def checked(self) -> Checked:
        """What the cycles judged that agreed checked."""
        changes, outputs, draws = self.replayer.agreed
        return Checked(
            changes + self._changes_checked,
            outputs + self._outputs_checked,
            draws + self._draws_checked,
            self._samples_perceived - self.divergences.samples_diverged,
        )

    @property
    def judging(self) -> bool:
        """Whether it still judges cycles: it has not stopped at a divergence."""
        return self._stopped_at is None

    def end(self) -> None:
        """Take the end of the session: what was followed past a divergence is written
        into it, and the samples perceived are counted."""
        if self._follower is not None:
            self._follower.end()
        if self._stopped_at is None:
            self._samples_perceived = self.replayer.samples_perceived

    def log_ended(self, why: str) -> None:
        """Record that the log stopped before the recording closed it."""
        context = self.executor.context
        self.divergences.log_ended(why, context.cycle, context.time_ns)

    def judge(
        self,
        index: int,
        record: CycleRecord,
        changes: list[StateChangeRecord] | None,
        outcome: CycleOutcome | None,
    ) -> Follower | None:
        """Judge a cycle that did not agree at once, the ``index``-th of its batch (see
        :meth:`~beatlog.replay.session.Judge.judge`): it agrees when it went cleanly
        (or only as an approved baseline lets it differ) and its state changes and
        outputs match: byte for byte, else by the :class:`Comparison` (state changes as
        a set, allowances applied). Only a cycle that does not agree gets its full
        outcome."""
        replayer = self.replayer
        cycle = self.executor.context.cycle
        if changes is None or cycle in self._pinned_cycles:
            outcome = outcome or replayer.outcome()  # judged by its robot state, then as usual
            agrees = self.divergences.agrees_but_for_pins(outcome)
            changes = outcome.changes if agrees else None
        unloggable: Exception | None = None
        if changes is not None:
            outputs = self.executor.context.outputs
            try:
                if replayer.agrees(record, changes) or (
                    self._changes_agree(record.state_changes, changes)
                    and self._outputs_agree(record.outputs, outputs)
                ):
                    self._changes_checked += len(changes)
                    self._outputs_checked += len(outputs)
                    self._draws_checked += len(replayer.random.recorded)  # it drew them all
                    return None
            except (TypeError, ValueError, msgspec.EncodeError) as exc:  # cannot be logged
                unloggable = exc
        outcome = outcome or replayer.outcome()
        if unloggable is not None:
            outcome = outcome._replace(failure=unloggable)
        self.divergences.add(outcome, index)
        if self._keep_going:
            return None
        self._stopped_at = (outcome.cycle + 1, outcome.time_ns)
        self._samples_perceived = replayer.samples_perceived
        self._follower = Follower(self.divergences)
        return self._follower

    def _expected_outputs(self, raw_outputs: msgspec.Raw) -> dict[str, Any]:
        cycle = self.executor.context.cycle
        return decode_part(self.path, raw_outputs, decode_outputs, "outputs", cycle)

    def _changes_agree(self, raw_changes: msgspec.Raw, changes: list[StateChangeRecord]) -> bool:
        actual = self.divergences.named_actual(changes)
        return self.comparison.changes_agree(self._named(raw_changes), actual)

    def _outputs_agree(self, raw_outputs: msgspec.Raw, outputs: dict[str, Any]) -> bool:
        return self.comparison.outputs_agree(self._expected_outputs(raw_outputs), outputs)

    def _named(self, raw_changes: msgspec.Raw) -> list[StateChange]:
        """Expected state changes in current names.

        :raises beatlog.errors.CorruptLogError: one names a behavior the catalogue lacks.
        """
        names = self.expected_names
        renamed = self.comparison.renamed
        cycle = self.executor.context.cycle
        recorded = decode_part(self.path, raw_changes, decode_state_changes, "state changes", cycle)
        for index, _, _ in recorded:
            if not 0 <= index < len(names):
                raise CorruptLogError(
                    self.path,
                    f"damaged state changes in cycle {cycle}: behavior "
                    f"#{index} is not in the catalogue of {len(names)}",
                )
        return [
            renamed(StateChange(names[index], before, after)) for index, before, after in recorded
        ]
