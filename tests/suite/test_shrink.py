"""Shrinking a failing DTC: the shortest window that fails the same way, written as a
spec beside it that ``beatlog test`` fails the same way."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.baseline.file import expected_path
from beatlog.baseline.policy import SpecOptions, UpdateMode
from beatlog.errors import BeatlogError
from beatlog.replay.perturbation import Perturbations
from beatlog.replay.verdict import DivergenceKind
from beatlog.suite.maintenance import approve, update_baselines
from beatlog.suite.runner import run_spec
from beatlog.suite.shrink import Attempt, NothingToShrinkError, shrink, shrunk_path
from beatlog.suite.spec import load_spec
from tests.conftest import Probe, RecordFn, distances, first_cycle_below
from tests.specs import CHANGED, PROBE, write_spec
from tests.systems import LINGER, WORN_OUT

WEARY = "tests.systems:weary_system"
FUSSY = "tests.systems:fussy_system"
FRAGILE = "tests.systems:fragile_system"
LINGERS = "tests.systems:NeverLingers"
WORN_OUT_CYCLE = first_cycle_below(0.5) + 100 * (WORN_OUT - 1)
"""Where the weary probe raises in a probe log: on its fourth approach to the pole."""


@pytest.fixture
def weary(tmp_path: Path, record_probe: RecordFn) -> Path:
    """A spec whose system raises at cycle 326 of its log's 600, on a state (three
    approaches made) that only the cycles after 250 reach."""
    return write_spec(tmp_path, "weary", record_probe(600), WEARY, tags=["wear"])


def test_a_failing_dtc_shrinks_to_a_window_that_ends_where_it_fails(weary: Path) -> None:
    shrunk = shrink(weary)

    assert shrunk.path == shrunk_path(weary) == weary.with_name("weary.shrunk.dtc.toml")
    assert (shrunk.failure.kind, shrunk.failure.behavior, shrunk.failure.invariant) == (
        DivergenceKind.EXCEPTION,
        "near",
        None,
    )
    assert shrunk.failure.cycle == shrunk.end_cycle == WORN_OUT_CYCLE
    assert 0 < shrunk.start_cycle <= shrunk.end_cycle
    assert shrunk.cycles_before == WORN_OUT_CYCLE + 1
    assert shrunk.perturbations_before == shrunk.perturbations == ()


def test_a_failure_that_depends_on_history_replays_the_cycles_before_its_window(
    weary: Path,
) -> None:
    tried: list[Attempt] = []

    shrunk = shrink(weary, progress=tried.append)

    assert (shrunk.start_cycle, shrunk.end_cycle) == (WORN_OUT_CYCLE, WORN_OUT_CYCLE)
    assert not shrunk.fresh_start  # the near of a fresh start has made no approach yet
    assert shrunk.cycles_replayed == WORN_OUT_CYCLE + 1
    assert any(attempt.fresh_start for attempt in tried)  # tried first, and failed
    assert not load_spec(shrunk.path).fresh_start


def test_a_variant_failing_for_a_short_history_starts_fresh_where_that_begins(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    calm = [Probe(distance=1.0)] * 1000  # the pole first comes near at cycle 1026
    log = record_probe(states=[*calm, *(Probe(distance=d) for d in distances(400))])
    spec = write_spec(tmp_path, "weary-later", log, WEARY, variant=1, variants={"draws": True})
    worn_out = 1000 + WORN_OUT_CYCLE

    shrunk = shrink(spec)

    assert (shrunk.failure.cycle, shrunk.end_cycle, shrunk.fresh_start) == (
        worn_out,
        worn_out,
        True,
    )
    last_near = max(t for t, d in enumerate(distances(100)) if d < 0.5)
    assert shrunk.start_cycle == 1000 + last_near  # a fresh near takes it for the first approach
    assert shrunk.cycles_replayed < worn_out - 1000


def test_a_failure_that_does_not_depend_on_history_starts_fresh_at_the_failing_cycle(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    spec = write_spec(tmp_path, "fragile", record_probe(600), FRAGILE)
    cycle = first_cycle_below(0.3)

    shrunk = shrink(spec)

    assert (shrunk.failure.kind, shrunk.failure.behavior, shrunk.failure.cycle) == (
        DivergenceKind.EXCEPTION,
        "dice",
        cycle,
    )
    assert (shrunk.start_cycle, shrunk.end_cycle, shrunk.fresh_start) == (cycle, cycle, True)
    assert shrunk.cycles_replayed == 1
    written = load_spec(shrunk.path)
    assert (written.start_cycle, written.end_cycle, written.fresh_start) == (cycle, cycle, True)
    again = run_spec(written)
    assert again.result is not None
    failure = again.result.divergence
    assert failure is not None
    assert (failure.kind, failure.behavior, failure.cycle) == (
        DivergenceKind.EXCEPTION,
        "dice",
        cycle,
    )


def test_the_shrunk_spec_names_the_same_log_and_system_with_its_window(weary: Path) -> None:
    shrunk = shrink(weary)

    spec, original = load_spec(shrunk.path), load_spec(weary)

    assert spec.name == shrunk.name == "weary-shrunk"
    assert (spec.log.resolve(), spec.system, spec.tags) == (
        original.log.resolve(),
        WEARY,
        ("wear",),
    )
    assert (spec.start_cycle, spec.end_cycle) == (shrunk.start_cycle, shrunk.end_cycle)


def test_a_failing_invariant_keeps_the_cycles_it_looks_across(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    spec = write_spec(tmp_path, "linger", record_probe(600), PROBE, invariants=[LINGERS])
    first_near = first_cycle_below(0.5)

    shrunk = shrink(spec)

    assert (shrunk.failure.kind, shrunk.failure.invariant) == (
        DivergenceKind.INVARIANT,
        "NeverLingers",
    )
    assert shrunk.failure.cycle == shrunk.end_cycle == first_near + LINGER
    assert shrunk.start_cycle <= first_near  # the cycles it looks across, from rest
    assert shrunk.fresh_start
    assert shrunk.cycles_replayed < first_near + LINGER + 1


def test_a_dtc_judged_against_its_approved_baseline_is_shrunk_with_a_copy_of_it(
    tmp_path: Path, record_probe: RecordFn, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("CI", raising=False)
    log = record_probe(600)
    spec = write_spec(tmp_path, "retuned", log, CHANGED)
    update_baselines(
        [run_spec(load_spec(spec), SpecOptions(update=UpdateMode.NEW))], UpdateMode.NEW
    )
    approve([spec])
    write_spec(tmp_path, "retuned", log, "tests.systems:weary_system_changed")  # a bug on top

    shrunk = shrink(spec)

    assert expected_path(shrunk.path).read_bytes() == expected_path(spec).read_bytes()
    outcome = run_spec(load_spec(shrunk.path))
    assert outcome.baseline == expected_path(shrunk.path)
    assert outcome.result is not None
    failure = outcome.result.divergence
    assert failure is not None
    assert (failure.kind, failure.behavior, failure.cycle) == (
        DivergenceKind.EXCEPTION,
        "near",
        shrunk.failure.cycle,
    )


def test_every_replay_tried_after_the_first_stops_at_the_failing_cycle(weary: Path) -> None:
    tried: list[Attempt] = []

    shrunk = shrink(weary, progress=tried.append)

    first, *rest = tried
    assert (first.end_cycle, first.failed) == (None, True)
    assert rest
    assert all(attempt.end_cycle == WORN_OUT_CYCLE for attempt in rest)
    assert [attempt.replays for attempt in tried] == list(range(1, shrunk.replays + 1))


def test_a_failing_variant_keeps_only_the_perturbations_it_needs(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    perturbations = {
        "draws": True,
        "heartbeat_jitter": 0.002,
        "noise": {"distance": 0.3, "reading": 0.5},
        "drop_samples": 0.0,
    }
    spec = write_spec(
        tmp_path, "fussy", record_probe(600), FUSSY, variant=1, variants=perturbations
    )

    shrunk = shrink(spec)

    assert (shrunk.failure.kind, shrunk.failure.behavior) == (DivergenceKind.EXCEPTION, "near")
    assert shrunk.perturbations_before == (
        "draws",
        "heartbeat_jitter",
        "noise.distance",
        "noise.reading",
    )
    assert shrunk.perturbations == ("noise.distance",)
    assert shrunk.failure.cycle == shrunk.end_cycle
    written = load_spec(shrunk.path)
    assert written.variant == 1
    assert written.perturbations == Perturbations(draws=False, noise={"distance": 0.3})
    again = run_spec(written)
    assert again.result is not None
    assert again.result.divergence is not None
    failure = again.result.divergence
    assert (failure.kind, failure.behavior, failure.cycle) == (
        DivergenceKind.EXCEPTION,
        "near",
        shrunk.failure.cycle,
    )


def test_a_variant_failing_an_invariant_keeps_the_same_invariant_failing(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    perturbations = {"heartbeat_jitter": 0.002, "noise": {"distance": 0.3}}
    spec = write_spec(
        tmp_path,
        "negative",
        record_probe(600),
        PROBE,
        invariants=["tests.systems:never_negative"],
        variant=2,
        variants=perturbations,
    )

    shrunk = shrink(spec)

    assert (shrunk.failure.kind, shrunk.failure.invariant) == (
        DivergenceKind.INVARIANT,
        "never_negative",
    )
    assert shrunk.perturbations == ("noise.distance",)
    assert shrunk.start_cycle == shrunk.end_cycle == shrunk.failure.cycle  # a cycle's noise alone


def test_a_spec_that_passes_has_nothing_to_shrink(tmp_path: Path, record_probe: RecordFn) -> None:
    spec = write_spec(tmp_path, "calm", record_probe(60), PROBE)

    with pytest.raises(NothingToShrinkError) as raised:
        shrink(spec)

    assert str(raised.value) == f"{spec}: nothing to shrink: it passes"
    assert not shrunk_path(spec).exists()


def test_a_spec_whose_window_ends_past_its_log_is_an_error_naming_it(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    spec = write_spec(tmp_path, "long", record_probe(60), WEARY, end_cycle=60)

    with pytest.raises(BeatlogError) as raised:
        shrink(spec)

    assert str(raised.value) == (f"{spec}: end_cycle 60 is past the log's last cycle (59)")
