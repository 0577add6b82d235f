"""Shrinking a failing DTC: the shortest window of cycles, and the fewest perturbations,
that still fail the same way, written as a spec of their own.

:func:`shrink` cuts a failing DTC down by delta debugging on the spec's data, each try a
replay that stops at its window's end: the window ends where the DTC failed; its
perturbations (the spec's ``[variants]`` table) are taken out one at a time, each kept
out where the DTC still fails the same way; its start is the latest that still fails the
same way, stepped back from the failing cycle in doubling strides, then bisected. First
from a fresh start (the behaviors from rest there, the cycles before it not replayed),
then with the cycles before it replayed as recorded, rebuilding the behaviors' state;
the fresh start is kept unless the failure needs so long a history that its window
costs about as much as replaying up to the other's.

"The same way" is the same kind of divergence in the same behavior (or invariant),
wherever in the window it comes; from a fresh start, in the cycle where the spec fails,
since one that fails earlier fails for want of the history it left out. The result is
written beside the spec as ``<stem>.shrunk.dtc.toml``, named ``<name>-shrunk``, with the
same log, its window and the perturbations left, and a copy of the spec's approved
baseline, so that it is judged as the tries were.
"""

from __future__ import annotations

import dataclasses
import shutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

from beatlog.baseline.file import SPEC_SUFFIX, expected_path
from beatlog.baseline.policy import SpecOptions
from beatlog.errors import BeatlogError, SpecError
from beatlog.log.files import replacing
from beatlog.replay.verdict import Divergence, DivergenceKind
from beatlog.suite.runner import Verdict, run_spec
from beatlog.suite.spec import read_spec_data, spec_from_data, spec_toml

__all__ = ["Attempt", "NothingToShrinkError", "Shrunk", "shrink", "shrunk_path"]


class NothingToShrinkError(BeatlogError):
    """The spec passes: there is no failure to shrink."""


class Attempt(NamedTuple):
    """One replay a shrink tried: its window, and whether it failed the same way."""

    start_cycle: int
    end_cycle: int | None
    """None: the log's last cycle."""
    perturbations: int
    """The perturbations it kept."""
    failed: bool
    replays: int
    """The replays tried so far, this one included."""
    fresh_start: bool = False
    """Whether it started the behaviors from rest at ``start_cycle``."""


@dataclass(frozen=True)
class Shrunk:
    """What :func:`shrink` found, and where it wrote it."""

    path: Path
    """The shrunk spec written."""
    name: str
    failure: Divergence
    """How the shrunk spec fails: the same way as the spec, in its window."""
    start_cycle: int
    end_cycle: int
    fresh_start: bool
    """Whether the behaviors start from rest at ``start_cycle``, the cycles before it
    not replayed (else they replay as recorded to rebuild the behaviors' state)."""
    cycles_before: int
    """The cycles the spec's replay stepped through to its failure."""
    perturbations_before: tuple[str, ...]
    perturbations: tuple[str, ...]
    """The perturbations left, by name (``noise.battery``, ``heartbeat_jitter``)."""
    replays: int
    """The replays tried, the first (the spec as given) included."""

    @property
    def cycles_judged(self) -> int:
        """The cycles the shrunk spec judges."""
        return self.end_cycle - self.start_cycle + 1

    @property
    def cycles_replayed(self) -> int:
        """The cycles the shrunk spec replays: those it judges, and from a start that is
        not fresh, those before them."""
        return self.cycles_judged if self.fresh_start else self.end_cycle + 1


def shrunk_path(spec: Path) -> Path:
    """Where the shrunk spec of the spec at ``spec`` is written."""
    stem = spec.name.removesuffix(SPEC_SUFFIX) if spec.name.endswith(SPEC_SUFFIX) else spec.stem
    return spec.with_name(f"{stem}.shrunk{SPEC_SUFFIX}")


def shrink(spec: Path, *, progress: Callable[[Attempt], object] | None = None) -> Shrunk:
    """Shrink the failing DTC of the spec at ``spec`` (see the module) and write the
    result beside it; ``progress`` is told of every replay tried, each judged as
    ``beatlog test`` judges the spec.

    :raises NothingToShrinkError: the spec passes.
    :raises beatlog.errors.SpecError: the spec cannot be read, or fails only because
        its log was cut off, or not repeatably.
    :raises beatlog.errors.BeatlogError: the spec cannot run (its log or system is bad
        input, its window past the log's end).
    """
    data = read_spec_data(spec)
    search = _Search(spec, data, progress)
    first = search.first()
    if first is None:
        raise NothingToShrinkError(f"{spec}: nothing to shrink: it passes")
    if first.kind is DivergenceKind.LOG_ENDED:
        raise SpecError(spec, "fails only because its log was cut off: no window repeats that")
    before = _perturbations(data.get("variants", {}))
    if not search.fails(search.start, first.cycle):
        raise SpecError(
            spec,
            f"fails at cycle {first.cycle} and then not there: its behaviors are not "
            "deterministic (beatlog test --audit finds the call)",
        )
    search.end = first.cycle
    kept = search.fewest(before)
    search.latest_start()
    shrunk = shrunk_path(spec)
    name = f"{data['name']}-shrunk"
    written = {
        **{key: value for key, value in data.items() if key not in ("variants", "fresh_start")},
        "name": name,
        "start_cycle": search.start,
        "end_cycle": search.end,
        **({"fresh_start": True} if search.fresh else {}),
        **({"variants": kept} if "variants" in data else {}),
    }
    spec_from_data(shrunk, written)  # what is written loads
    _write(spec, shrunk, spec_toml(written))
    return Shrunk(
        path=shrunk,
        name=name,
        failure=search.failure,
        start_cycle=search.start,
        end_cycle=search.end,
        fresh_start=search.fresh,
        cycles_before=first.cycle + 1,
        perturbations_before=before,
        perturbations=_perturbations(kept),
        replays=search.replays,
    )


class _Search:
    """The tries of one shrink: each replays the spec's data with a window and
    perturbations, and says whether it failed the same way as the spec."""

    def __init__(
        self, path: Path, data: Mapping[str, Any], progress: Callable[[Attempt], object] | None
    ) -> None:
        self._path = path
        self._data = dict(data)
        self._progress = progress
        given = spec_from_data(path, data)
        self.start = given.start_cycle
        self.end: int | None = given.end_cycle
        self.fresh = given.fresh_start
        self.perturbations: dict[str, Any] = dict(data.get("variants", {}))
        self.replays = 0
        self._same: tuple[DivergenceKind, str | None, str | None] | None = None
        self.failure: Divergence

    def first(self) -> Divergence | None:
        """Replay the spec as given: its failure, which the tries must repeat, or None."""
        divergence = self._replay(self.start, self.end)
        if divergence is not None:
            self._same = divergence.kind, divergence.behavior, divergence.invariant
        return divergence

    def fails(
        self,
        start: int,
        end: int | None,
        perturbations: Mapping[str, Any] | None = None,
        *,
        fresh: bool | None = None,
    ) -> bool:
        """Whether the spec fails the same way in the window ``start``-``end``, not
        before it, with ``perturbations`` (by default, those kept so far); from a
        ``fresh`` start (by default, as kept so far), in the cycle it failed in last."""
        return self._replay(start, end, perturbations, fresh, same=True) is not None

    def fewest(self, given: tuple[str, ...]) -> dict[str, Any]:
        """Take out each perturbation in turn, keeping it out where the spec still fails
        the same way (one-minimal, as delta debugging ends); the window's end moves to
        where the last failure came."""
        for name in given:
            fewer = _without(self.perturbations, name)
            if self.fails(self.start, self.end, fewer):
                self.perturbations = fewer
                self.end = self.failure.cycle
        return self.perturbations

    def latest_start(self) -> None:
        """The window's start: the latest that fails the same way from a fresh start,
        found first (its tries cost their windows alone), then the latest after it that
        fails with the cycles before it replayed. The fresh start is kept where the
        cycles it leaves unreplayed outnumber those it judges beyond the other's."""
        end = self.failure.cycle
        known = self.fresh and self.start > 0
        fresh = self._latest(end, max(self.start, 1), fresh=True, known=known)
        replayed = None
        if fresh is None or fresh[0] < end:  # a later start may still fail, replayed to
            lowest = self.start if fresh is None else fresh[0] + 1
            known = fresh is None and not self.fresh
            replayed = self._latest(end, lowest, fresh=False, known=known)
        if fresh is not None and (replayed is None or fresh[0] > replayed[0] - fresh[0]):
            (self.start, self.failure), self.fresh = fresh, True
        elif replayed is not None:
            (self.start, self.failure), self.fresh = replayed, False
        self.end = end

    def _latest(
        self, end: int, lowest: int, *, fresh: bool, known: bool
    ) -> tuple[int, Divergence] | None:
        """The latest start from ``lowest`` to ``end`` whose window fails the same way
        from a ``fresh`` start or not, and its failure (None where none does): stepped
        back in doubling strides until one fails, then bisected. ``known``: ``lowest``
        fails so, and is not tried again."""
        if lowest > end:
            return None
        passed, stride, candidate = end + 1, 1, end
        while not (candidate == lowest and known) and not self.fails(candidate, end, fresh=fresh):
            if candidate == lowest:
                return None
            passed = candidate
            candidate = max(lowest, end + 1 - 2 * stride)
            stride *= 2
        failing, found = candidate, self.failure
        while passed - failing > 1:
            middle = (failing + passed) // 2
            if self.fails(middle, end, fresh=fresh):
                failing, found = middle, self.failure
            else:
                passed = middle
        return failing, found

    def _replay(
        self,
        start: int,
        end: int | None,
        perturbations: Mapping[str, Any] | None = None,
        fresh: bool | None = None,
        *,
        same: bool = False,
    ) -> Divergence | None:
        """The divergence of one replay of the spec's data with this window, from a
        ``fresh`` start or not, told to ``progress`` and kept as :attr:`failure`; with
        ``same``, only one that fails the same way (see :meth:`fails`)."""
        perturbations = self.perturbations if perturbations is None else perturbations
        fresh = self.fresh if fresh is None else fresh
        data = {**self._data, "start_cycle": start, "fresh_start": fresh}
        if end is None:
            data.pop("end_cycle", None)
        else:
            data["end_cycle"] = end
        if "variants" in self._data:
            data["variants"] = dict(perturbations)
        spec = dataclasses.replace(spec_from_data(self._path, data), allow_empty=True)
        self.replays += 1
        outcome = run_spec(spec, SpecOptions(verdict_only=True))
        if outcome.verdict is Verdict.ERROR:  # bad input: its error names the file
            cannot = BeatlogError(outcome.error)
            cannot.user_traceback = outcome.error_traceback
            raise cannot
        assert outcome.result is not None  # a verdict that is no error has its result
        divergence = outcome.result.divergence
        if same and not (
            divergence is not None
            and divergence.cycle >= start
            and (divergence.kind, divergence.behavior, divergence.invariant) == self._same
            and (not fresh or divergence.cycle == self.failure.cycle)
        ):
            divergence = None
        if divergence is not None:
            self.failure = divergence
        if self._progress is not None:
            kept = len(_perturbations(perturbations))
            self._progress(Attempt(start, end, kept, divergence is not None, self.replays, fresh))
        return divergence


def _perturbations(table: Mapping[str, Any]) -> tuple[str, ...]:
    """The perturbations a ``[variants]`` table declares, by name: each of its keys but
    ``count`` that is on (``draws = true``, a bound above 0), and each field of its
    ``noise`` with a bound above 0 (``noise.battery``)."""
    named: list[str] = []
    for key, value in table.items():
        if isinstance(value, Mapping):
            named.extend(f"{key}.{field}" for field, bound in value.items() if bound)
        elif value and key != "count":
            named.append(key)
    return tuple(named)


def _without(table: Mapping[str, Any], name: str) -> dict[str, Any]:
    """The perturbations ``table`` without the one named: turned off where it is a key
    (``draws = false``, a bound of 0, so that no default takes its place), left out where
    it is a field of a table."""
    fewer = dict(table)
    key, _, field = name.partition(".")
    if field:
        fewer[key] = {k: v for k, v in fewer[key].items() if k != field}
    else:
        fewer[key] = False if isinstance(fewer[key], bool) else 0.0
    return fewer


def _write(spec: Path, shrunk: Path, text: str) -> None:
    """Write the shrunk spec, whole or not at all, and beside it a copy of the spec's
    approved baseline, if it has one.

    :raises beatlog.errors.SpecError: it cannot be written.
    """
    baseline = expected_path(spec)
    try:
        if baseline.exists():
            with replacing(expected_path(shrunk)) as file, baseline.open("rb") as source:
                shutil.copyfileobj(source, file)
        with replacing(shrunk) as file:
            file.write(text.encode())
    except OSError as exc:
        raise SpecError(shrunk, f"cannot write: {exc.strerror or exc}") from None
